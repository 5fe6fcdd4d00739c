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

#define MAX_MARKS 64
static uint64_t insns;
static bool riscv;
static uint64_t marks[MAX_MARKS];
static unsigned n_marks;

/* The TB's whole length was added when it was entered: subtract the
 * instructions after the mark, which have not run yet. */
static void on_mark(unsigned int vcpu, void *after) {
    (void)vcpu;
    if (n_marks < MAX_MARKS) {
        marks[n_marks++] = insns - (uint64_t)(uintptr_t)after;
    }
}

static void on_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &insns, n);
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
}

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv) {
    (void)argc; (void)argv;
    riscv = strncmp(info->target_name, "riscv", 5) == 0;
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_trans);
    qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
    return 0;
}
