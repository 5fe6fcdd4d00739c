/* Minimal QEMU TCG plugin (API v1, QEMU 7.2): count executed guest
 * instructions, and the count at every phase mark.
 *
 * At exit it prints `insns: N` (every instruction executed) and, if the
 * guest executed any, `marks: M1 M2 ...`: the number of instructions
 * executed up to and including each phase mark: on Arm the Thumb `yield`
 * hint (0xbf10), on RISC-V `slti x0, x0, 0x7ad` (0x7ad02013, a HINT the ISA
 * leaves for custom use). The micropt firmware places one between its phases
 * (setup, parse, render, dump); the compiler emits neither by itself. Counts
 * are exact and repeatable. Any guest architecture: the target's name
 * (`arm`, `riscv32`, ...) picks the mark.
 *
 * On a machine with several vCPUs (`smp_vcpus` > 1, e.g. mps2-an521's two
 * Cortex-M33) it counts per vCPU as well, and prints for each vCPU that ran
 * `cpuK insns: N` and `cpuK marks: ...`, its own instructions up to each of
 * its own marks (`insns` and `marks` stay the totals over all vCPUs, the
 * marks in the order they were executed). Per-vCPU counts take a callback
 * per translation block instead of an inline add: slower, so only then.
 *
 * Build: gcc -O2 -shared -fPIC -o libicount.so icount.c
 * (Debian ships no plugin header, so the few declarations needed are here.)
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct { const char *target_name; struct { int min, cur; } version; bool system_emulation;
                 union { struct { int smp_vcpus, max_vcpus; } system; }; } qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
typedef void (*tb_trans_cb)(qemu_plugin_id_t, struct qemu_plugin_tb *);
typedef void (*udata_cb)(qemu_plugin_id_t, void *);
typedef void (*vcpu_udata_cb)(unsigned int, void *);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t, tb_trans_cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *, enum qemu_plugin_op, void *, uint64_t);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *, size_t);
const void *qemu_plugin_insn_data(const struct qemu_plugin_insn *);
size_t qemu_plugin_insn_size(const struct qemu_plugin_insn *);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *, vcpu_udata_cb, enum qemu_plugin_cb_flags, void *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, udata_cb, void *);
void qemu_plugin_outs(const char *);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *, vcpu_udata_cb, enum qemu_plugin_cb_flags, void *);

#define MAX_MARKS 64
#define MAX_VCPUS 8
static uint64_t insns;
static bool riscv;
static uint64_t marks[MAX_MARKS];
static unsigned n_marks;
static bool per_vcpu;
static uint64_t vcpu_insns[MAX_VCPUS];
static uint64_t vcpu_marks[MAX_VCPUS][MAX_MARKS];
static unsigned vcpu_n_marks[MAX_VCPUS];

/* The TB's whole length was added when it was entered: subtract the
 * instructions after the mark, which have not run yet. */
static void on_mark(unsigned int vcpu, void *after) {
    if (n_marks < MAX_MARKS) {
        marks[n_marks++] = insns - (uint64_t)(uintptr_t)after;
    }
    if (per_vcpu && vcpu < MAX_VCPUS && vcpu_n_marks[vcpu] < MAX_MARKS) {
        vcpu_marks[vcpu][vcpu_n_marks[vcpu]++] = vcpu_insns[vcpu] - (uint64_t)(uintptr_t)after;
    }
}

/* Per-vCPU counting: each vCPU adds to its own counter (no shared writes
 * even when vCPUs run in parallel threads) and to the total (vCPUs run one
 * at a time under -icount, which the deterministic figures use). */
static void on_tb(unsigned int vcpu, void *n) {
    insns += (uint64_t)(uintptr_t)n;
    if (vcpu < MAX_VCPUS) {
        vcpu_insns[vcpu] += (uint64_t)(uintptr_t)n;
    }
}

static void on_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    if (per_vcpu) {
        qemu_plugin_register_vcpu_tb_exec_cb(tb, on_tb, QEMU_PLUGIN_CB_NO_REGS, (void *)(uintptr_t)n);
    } else {
        qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &insns, n);
    }
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        const uint8_t *d = qemu_plugin_insn_data(insn);
        size_t size = qemu_plugin_insn_size(insn);
        bool is_mark = riscv ? size == 4 && d[0] == 0x13 && d[1] == 0x20 && d[2] == 0xd0 && d[3] == 0x7a
                             : size == 2 && d[0] == 0x10 && d[1] == 0xbf;
        if (is_mark) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_mark, QEMU_PLUGIN_CB_NO_REGS,
                                                   (void *)(uintptr_t)(n - 1 - i));
        }
    }
}

static void on_exit_cb(qemu_plugin_id_t id, void *p) {
    (void)id; (void)p;
    char buf[64 + MAX_MARKS * 21];
    int len = snprintf(buf, sizeof buf, "insns: %" PRIu64 "\n", insns);
    if (n_marks > 0) {
        len += snprintf(buf + len, sizeof buf - len, "marks:");
        for (unsigned i = 0; i < n_marks; i++) {
            len += snprintf(buf + len, sizeof buf - len, " %" PRIu64, marks[i]);
        }
        snprintf(buf + len, sizeof buf - len, "\n");
    }
    qemu_plugin_outs(buf);
    for (unsigned v = 0; per_vcpu && v < MAX_VCPUS; v++) {
        if (vcpu_insns[v] == 0) {
            continue;
        }
        len = snprintf(buf, sizeof buf, "cpu%u insns: %" PRIu64 "\n", v, vcpu_insns[v]);
        if (vcpu_n_marks[v] > 0) {
            len += snprintf(buf + len, sizeof buf - len, "cpu%u marks:", v);
            for (unsigned i = 0; i < vcpu_n_marks[v]; i++) {
                len += snprintf(buf + len, sizeof buf - len, " %" PRIu64, vcpu_marks[v][i]);
            }
            snprintf(buf + len, sizeof buf - len, "\n");
        }
        qemu_plugin_outs(buf);
    }
}

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv) {
    (void)argc; (void)argv;
    per_vcpu = info->system_emulation && info->system.smp_vcpus > 1;
    riscv = strncmp(info->target_name, "riscv", 5) == 0;
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_trans);
    qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
    return 0;
}
