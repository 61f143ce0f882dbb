#!/usr/bin/env python3
# UF2, the file a Pico takes by drag and drop on its BOOTSEL drive: the
# image cut into 256-byte pieces, each in a 512-byte block that names its
# flash address, so the boot ROM can write blocks in any order. picotool
# normally writes it from the ELF; it is not available here, so this writes
# it from the firmware's flat image (firmware.bin, which starts at the
# RP2040's flash base, XIP 0x10000000).
#
# Block layout (little-endian words): magic 0x0A324655, magic 0x9E5D5157,
# flags, target address, payload size, block number, number of blocks,
# family id (flag 0x2000 says the word is one), 476 bytes of data (the
# payload first, zeros after), final magic 0x0AB16F30.
#
#   python3 tools/uf2.py firmware.bin firmware.uf2     write
#   python3 tools/uf2.py --info firmware.uf2           base, size, blocks
import struct
import sys

MAGIC0 = 0x0A324655
MAGIC1 = 0x9E5D5157
MAGIC_END = 0x0AB16F30
FLAG_FAMILY = 0x00002000
FLAG_NOT_MAIN_FLASH = 0x00000001
RP2040_FAMILY = 0xE48BFF56
FLASH_BASE = 0x10000000
PAYLOAD = 256
BLOCK = 512
_HEAD = struct.Struct("<8I")


class UF2Error(ValueError):
    """A file that is not a well-formed UF2 for one image."""


def write(image, base=FLASH_BASE, family=RP2040_FAMILY):
    """The UF2 bytes for a flat image that starts at `base` (256-byte payloads, the last one zero-padded)."""
    count = (len(image) + PAYLOAD - 1) // PAYLOAD
    out = bytearray(count * BLOCK)
    for n in range(count):
        chunk = image[n * PAYLOAD:(n + 1) * PAYLOAD]
        at = n * BLOCK
        _HEAD.pack_into(out, at, MAGIC0, MAGIC1, FLAG_FAMILY, base + n * PAYLOAD, PAYLOAD, n, count, family)
        out[at + 32:at + 32 + len(chunk)] = chunk
        struct.pack_into("<I", out, at + BLOCK - 4, MAGIC_END)
    return bytes(out)


def read(data, family=RP2040_FAMILY):
    """(base address, flat image) from UF2 bytes; gaps between blocks read as 0xFF (erased flash).

    Raises UF2Error on a bad magic, a block count that disagrees, a missing
    block or another family's block."""
    if not data or len(data) % BLOCK:
        raise UF2Error("size %d is not a whole number of %d-byte blocks" % (len(data), BLOCK))
    pieces = {}
    total = None
    for at in range(0, len(data), BLOCK):
        m0, m1, flags, addr, size, no, count, fam = _HEAD.unpack_from(data, at)
        (end,) = struct.unpack_from("<I", data, at + BLOCK - 4)
        if m0 != MAGIC0 or m1 != MAGIC1 or end != MAGIC_END:
            raise UF2Error("block %d: bad magic" % (at // BLOCK))
        if flags & FLAG_NOT_MAIN_FLASH:
            continue
        if flags & FLAG_FAMILY and fam != family:
            raise UF2Error("block %d: family 0x%08x, not 0x%08x" % (at // BLOCK, fam, family))
        if size > 476 or (total is not None and count != total) or no >= count:
            raise UF2Error("block %d: size %d, number %d of %d" % (at // BLOCK, size, no, count))
        total = count
        pieces[no] = (addr, data[at + 32:at + 32 + size])
    if total is None or len(pieces) != total:
        raise UF2Error("%d of %s blocks present" % (len(pieces), total))
    base = min(a for a, _ in pieces.values())
    top = max(a + len(p) for a, p in pieces.values())
    image = bytearray(b"\xff" * (top - base))
    for addr, payload in pieces.values():
        image[addr - base:addr - base + len(payload)] = payload
    return base, bytes(image)


def main(argv):
    if len(argv) == 2 and argv[0] == "--info":
        with open(argv[1], "rb") as f:
            base, image = read(f.read())
        print("base 0x%08x, %d bytes, %d blocks" % (base, len(image), (len(image) + PAYLOAD - 1) // PAYLOAD))
        return 0
    if len(argv) != 2:
        print("usage: uf2.py IMAGE.bin OUT.uf2 | --info FILE.uf2", file=sys.stderr)
        return 2
    with open(argv[0], "rb") as f:
        image = f.read()
    with open(argv[1], "wb") as f:
        f.write(write(image))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
