#!/usr/bin/env python3
"""ELF -> UF2 for the Raspberry Pi boot ROMs, and checks of a Pico ELF's boot
block and of a UF2 file, for .ci/boards.sh (no elf2uf2-rs or picotool
install needed: those take minutes to build in CI).

    uf2.py convert ELF OUT.uf2 FAMILY   write the UF2 of ELF's loadable bytes
    uf2.py check   ELF UF2 FAMILY       the UF2 holds exactly ELF's loadable
                                        bytes, in well-formed blocks
    uf2.py boot2   ELF                  RP2040: a 256-byte .boot2 at
                                        0x10000000 whose CRC32 the boot ROM
                                        accepts
    uf2.py imagedef ELF                 RP2350: a block (0xffffded3 ...
                                        0xab123579) holding an IMAGE_DEF item
                                        within the first 4 KiB of flash
    uf2.py selftest                     the checks above fail on broken input

FAMILY: rp2040 (0xe48bff56) or rp2350-arm-s (0xe48bff59).

UF2 (github.com/microsoft/uf2): 512-byte blocks, each with magic numbers
0x0a324655 0x9e5d5157 at the start and 0x0ab16f30 at the end, flags (0x2000:
the file-size word holds a family id), the target address, a 256-byte
payload (what the Raspberry Pi boot ROMs accept: one flash page), the block
number and the block count. Like the Pico SDK's elf2uf2, the payload is the
ELF's PT_LOAD segments at their load (physical) addresses, in 256-byte pages,
gaps inside a page filled with zeros; only flash (0x10000000..0x20000000)
is written.
"""

import struct
import sys

FAMILIES = {"rp2040": 0xE48BFF56, "rp2350-arm-s": 0xE48BFF59}
MAGIC0, MAGIC1, MAGIC_END = 0x0A324655, 0x9E5D5157, 0x0AB16F30
FLAG_FAMILY = 0x00002000
PAGE = 256
FLASH = (0x10000000, 0x20000000)


class Bad(Exception):
    """A check failed: the message says what is wrong."""


def elf32(data):
    """(sections, loads) of a little-endian ELF32: sections as name ->
    (addr, offset, size, type), loads as (paddr, bytes) of PT_LOAD segments
    with file contents."""
    if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:
        raise Bad("not a little-endian ELF32 file")
    (phoff, shoff) = struct.unpack_from("<II", data, 28)
    (phentsize, phnum, shentsize, shnum, shstrndx) = struct.unpack_from("<HHHHH", data, 42)
    loads = []
    for i in range(phnum):
        p_type, p_off, _vaddr, p_paddr, p_filesz = struct.unpack_from("<IIIII", data, phoff + i * phentsize)
        if p_type == 1 and p_filesz > 0:
            loads.append((p_paddr, data[p_off : p_off + p_filesz]))
    sh = [struct.unpack_from("<IIIIII", data, shoff + i * shentsize) for i in range(shnum)]
    strtab_off = sh[shstrndx][4]
    sections = {}
    for name, typ, _flags, addr, off, size in sh:
        end = data.index(b"\0", strtab_off + name)
        sections[data[strtab_off + name : end].decode()] = (addr, off, size, typ)
    return sections, loads


def pages_of(loads):
    """The flash pages the loadable bytes touch: address -> 256 bytes."""
    pages = {}
    for addr, blob in loads:
        if not (FLASH[0] <= addr and addr + len(blob) <= FLASH[1]):
            raise Bad(f"segment at {addr:#010x} (+{len(blob)}) is not in flash")
        for i, b in enumerate(blob):
            a = addr + i
            page = pages.setdefault(a & ~(PAGE - 1), bytearray(PAGE))
            page[a & (PAGE - 1)] = b
    return pages


def convert(elf_data, family):
    pages = pages_of(elf32(elf_data)[1])
    n = len(pages)
    out = bytearray()
    for k, addr in enumerate(sorted(pages)):
        head = struct.pack("<8I", MAGIC0, MAGIC1, FLAG_FAMILY, addr, PAGE, k, n, family)
        out += head + pages[addr] + bytes(476 - PAGE) + struct.pack("<I", MAGIC_END)
    return bytes(out)


def check(elf_data, uf2, family):
    """Raises Bad unless `uf2` is well-formed and writes exactly the ELF's
    flash pages; returns (blocks, first address)."""
    if len(uf2) == 0 or len(uf2) % 512:
        raise Bad(f"UF2 size {len(uf2)} is not a positive multiple of 512")
    want = pages_of(elf32(elf_data)[1])
    n = len(uf2) // 512
    got = {}
    for k in range(n):
        blk = uf2[k * 512 : (k + 1) * 512]
        m0, m1, flags, addr, size, no, count, fam = struct.unpack_from("<8I", blk)
        (end,) = struct.unpack_from("<I", blk, 508)
        if (m0, m1, end) != (MAGIC0, MAGIC1, MAGIC_END):
            raise Bad(f"block {k}: bad magic numbers")
        if flags != FLAG_FAMILY or fam != family:
            raise Bad(f"block {k}: flags {flags:#x} family {fam:#010x}, want {FLAG_FAMILY:#x} {family:#010x}")
        if size != PAGE or addr % PAGE:
            raise Bad(f"block {k}: {size} bytes at {addr:#010x}, want 256 at a page boundary")
        if no != k or count != n:
            raise Bad(f"block {k}: numbered {no} of {count}, want {k} of {n}")
        if addr in got:
            raise Bad(f"block {k}: page {addr:#010x} written twice")
        got[addr] = blk[32 : 32 + PAGE]
    if set(got) != set(want):
        missing = sorted(set(want) - set(got))[:4]
        extra = sorted(set(got) - set(want))[:4]
        raise Bad(f"UF2 pages differ from the ELF's: missing {[hex(a) for a in missing]}, extra {[hex(a) for a in extra]}")
    for a in sorted(want):
        if bytes(want[a]) != got[a]:
            raise Bad(f"page {a:#010x}: UF2 bytes differ from the ELF's")
    return n, min(got)


def crc32_mpeg2(data):
    """The RP2040 boot ROM's CRC32 of boot2: polynomial 0x04c11db7, initial
    value 0xffffffff, bits not reflected, no final XOR."""
    crc = 0xFFFFFFFF
    for b in data:
        crc ^= b << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7) if crc & 0x80000000 else (crc << 1)
            crc &= 0xFFFFFFFF
    return crc


def section_bytes(data, sections, name):
    if name not in sections:
        raise Bad(f"no {name} section")
    addr, off, size, typ = sections[name]
    if typ == 8:  # NOBITS
        raise Bad(f"{name} has no contents (NOBITS)")
    return addr, data[off : off + size]


def boot2(data):
    addr, b = section_bytes(data, elf32(data)[0], ".boot2")
    if addr != 0x10000000 or len(b) != 256:
        raise Bad(f".boot2 is {len(b)} bytes at {addr:#010x}, want 256 at 0x10000000")
    (crc,) = struct.unpack_from("<I", b, 252)
    if crc32_mpeg2(b[:252]) != crc:
        raise Bad(f".boot2's CRC32 {crc:#010x} is not its first 252 bytes' {crc32_mpeg2(b[:252]):#010x}: the boot ROM would not run it")
    return crc


def imagedef(data):
    """The RP2350 boot ROM scans the first 4 KiB of flash for a block:
    0xffffded3, items (each a word whose low 7 bits are the type and bits
    8..15 the size in words for 1-byte sizes), the last item (type 0x7f:
    BLOCK_LAST_ITEM), a relative link, 0xab123579. Checks such a block with
    an IMAGE_DEF item (type 0x42) lies wholly in the first 4 KiB."""
    sections, loads = elf32(data)
    pages = pages_of(loads)
    flash = bytearray()
    for a in range(FLASH[0], FLASH[0] + 4096, PAGE):
        flash += pages.get(a, bytes(PAGE))
    words = struct.unpack("<1024I", flash)
    for i, w in enumerate(words):
        if w != 0xFFFFDED3:
            continue
        j, found = i + 1, False
        while j < len(words):
            item = words[j]
            typ = item & 0x7F
            size = (item >> 8) & (0xFFFF if item & 0x80 else 0xFF)
            if typ == 0x7F:  # BLOCK_LAST_ITEM: size of the items, then link, end
                if j + 2 < len(words) and words[j + 2] == 0xAB123579 and found:
                    start, end = FLASH[0] + 4 * i, FLASH[0] + 4 * (j + 3)
                    holder = [n for n, (a, _o, size, _t) in sections.items() if a <= start and end <= a + size and n]
                    return start, end, holder[0] if holder else "?"

                break
            if typ == 0x42:
                found = True
            if size == 0:
                break
            j += size
    raise Bad("no block with an IMAGE_DEF item (0xffffded3 ... 0xab123579) in the first 4 KiB of flash")


def selftest():
    """Made-up ELFs: the checks pass on good input and fail on each break."""

    def elf(segments, sections):
        # ELF32 header, program headers, section data, section headers
        shstr = b"\0" + b"\0".join(n.encode() for n, _, _ in sections) + b"\0"
        body = bytearray()
        ph = bytearray()
        offs = []
        base = 52 + 32 * len(segments)
        for addr, blob in segments:
            offs.append(base + len(body))
            ph += struct.pack("<8I", 1, base + len(body), addr, addr, len(blob), len(blob), 5, 4)
            body += blob
        str_off = base + len(body)
        body += shstr
        sh = bytearray(40)
        name_off = 1
        for name, addr, size in sections:
            seg = next(k for k, (a, b) in enumerate(segments) if a <= addr < a + len(b))
            off = offs[seg] + addr - segments[seg][0]
            sh += struct.pack("<10I", name_off, 1, 2, addr, off, size, 0, 0, 4, 0)
            name_off += len(name) + 1
        sh += struct.pack("<10I", name_off, 3, 0, 0, str_off, len(shstr), 0, 0, 1, 0)
        shoff = base + len(body)
        hdr = b"\x7fELF\x01\x01\x01" + bytes(9)
        hdr += struct.pack("<HHIIIIIHHHHHH", 2, 40, 1, 0, 52, shoff, 0, 52, 32, len(segments), 40, len(sections) + 2, len(sections) + 1)
        return bytes(hdr + ph + body + sh)

    def expect_bad(what, f, *args):
        try:
            f(*args)
        except Bad as e:
            print(f"selftest: {what}: rejected ({e})")
            return
        raise SystemExit(f"selftest FAILED: {what} was accepted")

    b2 = bytearray(range(252))
    b2 += struct.pack("<I", crc32_mpeg2(b2))
    code = bytes((7 * i) & 0xFF for i in range(700))
    good = elf([(0x10000000, bytes(b2)), (0x10000100, code), (0x10000500, b"\x01\x02\x03")], [(".boot2", 0x10000000, 256)])
    fam = FAMILIES["rp2040"]
    u = convert(good, fam)
    n, first = check(good, u, fam)
    # pages 0x000 (boot2), 0x100..0x300 (code), 0x500 (3 bytes): not 0x400
    assert (n, first) == (5, 0x10000000), (n, first)
    boot2(good)
    # a broken boot2 CRC, boot2 at the wrong address or of the wrong size
    bad = bytearray(b2)
    bad[3] ^= 1
    expect_bad("boot2 with a wrong CRC", boot2, elf([(0x10000000, bytes(bad))], [(".boot2", 0x10000000, 256)]))
    expect_bad("boot2 at 0x10000100", boot2, elf([(0x10000100, bytes(b2))], [(".boot2", 0x10000100, 256)]))
    expect_bad("boot2 of 252 bytes", boot2, elf([(0x10000000, bytes(b2))], [(".boot2", 0x10000000, 252)]))
    # UF2 breaks: wrong family, a flipped payload byte, a missing block,
    # a bad magic number, a wrong block count
    expect_bad("UF2 of another family", check, good, u, FAMILIES["rp2350-arm-s"])
    flip = bytearray(u)
    flip[512 + 40] ^= 0xFF
    expect_bad("UF2 with a changed byte", check, good, bytes(flip), fam)
    expect_bad("UF2 missing its last block", check, good, u[:-512], fam)
    mag = bytearray(u)
    mag[508] ^= 1
    expect_bad("UF2 with a bad end magic", check, good, bytes(mag), fam)
    cnt = bytearray(u)
    struct.pack_into("<I", cnt, 24, 9)
    expect_bad("UF2 with a wrong block count", check, good, bytes(cnt), fam)
    expect_bad("segment outside flash", convert, elf([(0x20000000, code)], []), fam)
    # IMAGE_DEF: a block at 0x10000110 (after a vector table), and broken ones
    vt = bytes(0x110)
    blk = struct.pack("<5I", 0xFFFFDED3, 0x10210142, 0x000001FF, 0, 0xAB123579)
    start, end, _ = imagedef(elf([(0x10000000, vt + blk)], []))
    assert (start, end) == (0x10000110, 0x10000124), (hex(start), hex(end))
    expect_bad("no IMAGE_DEF", imagedef, elf([(0x10000000, vt + blk[:4] + bytes(24))], []))
    late = bytes(4096) + blk
    expect_bad("block past 4 KiB", imagedef, elf([(0x10000000, late)], []))
    noimg = struct.pack("<5I", 0xFFFFDED3, 0x00000243, 0x000001FF, 0, 0xAB123579)
    expect_bad("block without an IMAGE_DEF item", imagedef, elf([(0x10000000, vt + noimg)], []))
    noend = struct.pack("<5I", 0xFFFFDED3, 0x10210142, 0x000001FF, 0, 0)
    expect_bad("block without its end marker", imagedef, elf([(0x10000000, vt + noend)], []))
    print("selftest: ok")


def main(argv):
    try:
        if argv[:1] == ["convert"] and len(argv) == 4:
            data = open(argv[1], "rb").read()
            u = convert(data, FAMILIES[argv[3]])
            check(data, u, FAMILIES[argv[3]])
            open(argv[2], "wb").write(u)
            print(f"{argv[2]}: {len(u) // 512} blocks, family {argv[3]} ({FAMILIES[argv[3]]:#010x})")
        elif argv[:1] == ["check"] and len(argv) == 4:
            n, first = check(open(argv[1], "rb").read(), open(argv[2], "rb").read(), FAMILIES[argv[3]])
            print(f"{argv[2]}: {n} well-formed blocks from {first:#010x}, exactly the ELF's flash bytes")
        elif argv[:1] == ["boot2"] and len(argv) == 2:
            crc = boot2(open(argv[1], "rb").read())
            print(f".boot2: 256 bytes at 0x10000000, CRC32 {crc:#010x} correct")
        elif argv[:1] == ["imagedef"] and len(argv) == 2:
            start, end, section = imagedef(open(argv[1], "rb").read())
            print(f"IMAGE_DEF block: {start:#010x}..{end:#010x} (section {section}), within the first 4 KiB of flash")
        elif argv == ["selftest"]:
            selftest()
        else:
            sys.exit(__doc__)
    except Bad as e:
        sys.exit(f"error: {e}")


if __name__ == "__main__":
    main(sys.argv[1:])
