/* QEMU TCG plugin (API v1, QEMU 7.2): per-instruction execution counts, for
 * profiling the firmware by function and source line (tools/profile_report.py
 * maps the addresses through the ELF's line tables, inlined frames included).
 *
 * At exit it writes one "ADDR COUNT" line (hex address, decimal count) per
 * guest instruction executed to the file given as `out=FILE` (default
 * profile.txt). Counts are per translation block entry times the block's
 * instructions: exact unless a block is left early (exceptions).
 *
 * With `taken=FILE` it also writes, per block-ending instruction, "ADDR
 * COUNT" of the times the next block executed did not start right after it:
 * the branches taken (and, rarely, exceptions taken there), for
 * tools/cpi.py. This costs a callback per block executed (one vCPU only).
 * With `data=FILE`, "ADDR COUNT" per 8-byte line (ADDR its first byte) of
 * the data reads in the Arm code region (below 0x20000000: on the boards,
 * flash): literal pools and read-only tables, which a board reads through
 * its flash cache like code. A callback per load.
 * With `cache=FILE`, it runs the instruction fetches (each 8-byte line a
 * block touches, once per execution of the block) and those data reads, in
 * execution order, through a model of the RP2350's XIP cache (16 KiB,
 * two-way set-associative, 8-byte lines, random eviction) and writes the
 * accesses and misses (one vCPU).
 *
 * Build: gcc -O2 -shared -fPIC -o libprofile.so profile.c
 * Use:   qemu-system-arm ... -plugin ./libprofile.so,out=prof.txt -d plugin -kernel ELF
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct { const char *target_name; struct { int min, cur; } version; bool system_emulation;
                 union { struct { int smp_vcpus, max_vcpus; } system; }; } qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*tb_trans_cb)(qemu_plugin_id_t, struct qemu_plugin_tb *);
typedef void (*udata_cb)(qemu_plugin_id_t, void *);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t, tb_trans_cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *, enum qemu_plugin_op, void *, uint64_t);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *, size_t);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *);
size_t qemu_plugin_insn_size(const struct qemu_plugin_insn *);
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS };
typedef void (*vcpu_udata_cb)(unsigned int, void *);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *, vcpu_udata_cb, enum qemu_plugin_cb_flags, void *);
enum qemu_plugin_mem_rw { QEMU_PLUGIN_MEM_R = 1, QEMU_PLUGIN_MEM_W, QEMU_PLUGIN_MEM_RW };
typedef void (*vcpu_mem_cb)(unsigned int, uint32_t, uint64_t, void *);
bool qemu_plugin_mem_is_store(uint32_t);
void qemu_plugin_register_vcpu_mem_cb(struct qemu_plugin_insn *, vcpu_mem_cb, enum qemu_plugin_cb_flags,
                                      enum qemu_plugin_mem_rw, void *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, udata_cb, void *);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

struct tb { uint64_t count, taken, end, *lines; size_t n, nlines; struct tb *next; uint64_t addr[]; };
static struct tb *tbs;
static const char *out = "profile.txt";
static const char *taken_out;
static struct tb *prev;
static const char *data_out, *cache_out;
/* the cache model: 1024 sets of 2 ways, tags are line numbers + 1 */
static uint64_t tags[1024][2], rng = 0x2545f4914f6cdd1dull;
static uint64_t fetches, fetch_misses, reads, read_misses;

static int cache_miss(uint64_t line) {
    uint64_t *set = tags[line & 1023];
    if (set[0] == line + 1 || set[1] == line + 1) return 0;
    rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17;
    set[rng & 1] = line + 1;
    return 1;
}
/* data reads per 8-byte line of the code region: open addressing on the
   line number (1 << 20 slots, 512 KiB of distinct lines at most) */
#define SLOTS (1u << 20)
static uint64_t *line_addr, *line_count;

static void on_load(unsigned int vcpu, uint32_t info, uint64_t vaddr, void *p) {
    (void)vcpu; (void)p;
    if (vaddr >= 0x20000000u || qemu_plugin_mem_is_store(info)) return;
    if (cache_out) {
        reads++;
        read_misses += cache_miss(vaddr >> 3);
    }
    if (!data_out) return;
    uint64_t line = vaddr >> 3, key = line + 1;
    for (uint32_t h = (uint32_t)(line * 0x9e3779b1u) & (SLOTS - 1);; h = (h + 1) & (SLOTS - 1)) {
        if (line_addr[h] == key) { line_count[h]++; return; }
        if (!line_addr[h]) { line_addr[h] = key; line_count[h] = 1; return; }
    }
}

/* the block before this one was left by a jump unless this one starts where
   it ended */
static void on_exec(unsigned int vcpu, void *p) {
    (void)vcpu;
    struct tb *t = p;
    if (prev && t->addr[0] != prev->end) prev->taken++;
    prev = t;
    if (cache_out)
        for (size_t i = 0; i < t->nlines; i++) {
            fetches++;
            fetch_misses += cache_miss(t->lines[i]);
        }
}

static void on_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    struct tb *t = calloc(1, sizeof *t + n * sizeof(uint64_t));
    t->n = n;
    for (size_t i = 0; i < n; i++) t->addr[i] = qemu_plugin_insn_vaddr(qemu_plugin_tb_get_insn(tb, i));
    t->end = t->addr[n - 1] + qemu_plugin_insn_size(qemu_plugin_tb_get_insn(tb, n - 1));
    t->next = tbs; tbs = t;
    if (cache_out) {
        t->lines = calloc(2 * n, sizeof *t->lines);
        for (size_t i = 0; i < n; i++) {
            uint64_t a = t->addr[i], b = a + qemu_plugin_insn_size(qemu_plugin_tb_get_insn(tb, i)) - 1;
            for (uint64_t l = a >> 3; l <= b >> 3; l++)
                if (!t->nlines || t->lines[t->nlines - 1] != l) t->lines[t->nlines++] = l;
        }
    }
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &t->count, 1);
    if (taken_out || cache_out) qemu_plugin_register_vcpu_tb_exec_cb(tb, on_exec, QEMU_PLUGIN_CB_NO_REGS, t);
    if (data_out || cache_out)
        for (size_t i = 0; i < n; i++)
            qemu_plugin_register_vcpu_mem_cb(qemu_plugin_tb_get_insn(tb, i), on_load, QEMU_PLUGIN_CB_NO_REGS,
                                             QEMU_PLUGIN_MEM_RW, NULL);
}

static void on_exit_cb(qemu_plugin_id_t id, void *p) {
    (void)id; (void)p;
    FILE *f = fopen(out, "w");
    if (!f) return;
    for (struct tb *t = tbs; t; t = t->next)
        if (t->count)
            for (size_t i = 0; i < t->n; i++) fprintf(f, "%" PRIx64 " %" PRIu64 "\n", t->addr[i], t->count);
    fclose(f);
    if (taken_out && (f = fopen(taken_out, "w"))) {
        for (struct tb *t = tbs; t; t = t->next)
            if (t->taken) fprintf(f, "%" PRIx64 " %" PRIu64 "\n", t->addr[t->n - 1], t->taken);
        fclose(f);
    }
    if (cache_out && (f = fopen(cache_out, "w"))) {
        fprintf(f, "fetches %" PRIu64 " misses %" PRIu64 "\nreads %" PRIu64 " misses %" PRIu64 "\n", fetches,
                fetch_misses, reads, read_misses);
        fclose(f);
    }
    if (data_out && (f = fopen(data_out, "w"))) {
        for (uint32_t h = 0; h < SLOTS; h++)
            if (line_addr[h]) fprintf(f, "%" PRIx64 " %" PRIu64 "\n", (line_addr[h] - 1) << 3, line_count[h]);
        fclose(f);
    }
}

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv) {
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (strncmp(argv[i], "out=", 4) == 0) out = argv[i] + 4;
        if (strncmp(argv[i], "taken=", 6) == 0) taken_out = argv[i] + 6;
        if (strncmp(argv[i], "data=", 5) == 0) data_out = argv[i] + 5;
        if (strncmp(argv[i], "cache=", 6) == 0) cache_out = argv[i] + 6;
    }
    if (data_out) {
        line_addr = calloc(SLOTS, sizeof *line_addr);
        line_count = calloc(SLOTS, sizeof *line_count);
        if (!line_addr || !line_count) return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_trans);
    qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
    return 0;
}
