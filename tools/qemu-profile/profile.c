/* QEMU TCG plugin (API v1, QEMU 7.2): per-instruction execution counts, for
 * profiling the firmware by function and source line (tools/profile_report.py
 * maps the addresses through the ELF's line tables, inlined frames included).
 *
 * At exit it writes one "ADDR COUNT" line (hex address, decimal count) per
 * guest instruction executed to the file given as `out=FILE` (default
 * profile.txt). Counts are per translation block entry times the block's
 * instructions: exact unless a block is left early (exceptions).
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
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, udata_cb, void *);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

struct tb { uint64_t count; size_t n; struct tb *next; uint64_t addr[]; };
static struct tb *tbs;
static const char *out = "profile.txt";

static void on_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    struct tb *t = calloc(1, sizeof *t + n * sizeof(uint64_t));
    t->n = n;
    for (size_t i = 0; i < n; i++) t->addr[i] = qemu_plugin_insn_vaddr(qemu_plugin_tb_get_insn(tb, i));
    t->next = tbs; tbs = t;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &t->count, 1);
}

static void on_exit_cb(qemu_plugin_id_t id, void *p) {
    (void)id; (void)p;
    FILE *f = fopen(out, "w");
    if (!f) return;
    for (struct tb *t = tbs; t; t = t->next)
        if (t->count)
            for (size_t i = 0; i < t->n; i++) fprintf(f, "%" PRIx64 " %" PRIu64 "\n", t->addr[i], t->count);
    fclose(f);
}

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv) {
    (void)info;
    for (int i = 0; i < argc; i++) if (strncmp(argv[i], "out=", 4) == 0) out = argv[i] + 4;
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_trans);
    qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
    return 0;
}
