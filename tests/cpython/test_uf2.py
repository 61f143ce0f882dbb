# The UF2 writer (tools/uf2.py) that stands in for picotool: the Pico's boot
# ROM takes blocks of 512 bytes, each naming where its 256 bytes go; a
# block it cannot parse is skipped, so a writer that is off by a field
# gives a board that does not boot. Checked field by field against the
# format, round-tripped, and against the images `make firmware` wrote.
import os
import struct
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))

import uf2  # noqa: E402


def test_each_block_names_its_address_number_count_and_family():
    image = bytes(range(256)) * 3 + b"tail"  # 772 bytes: three full pieces and a short one
    out = uf2.write(image)
    assert len(out) == 4 * 512
    for n in range(4):
        blk = out[n * 512:(n + 1) * 512]
        m0, m1, flags, addr, size, no, count, fam = struct.unpack_from("<8I", blk)
        assert (m0, m1) == (0x0A324655, 0x9E5D5157)
        assert struct.unpack_from("<I", blk, 508)[0] == 0x0AB16F30
        assert flags == 0x2000 and fam == 0xE48BFF56  # the RP2040's family id
        assert addr == 0x10000000 + 256 * n and size == 256 and no == n and count == 4
        assert blk[32:32 + 256] == (image[n * 256:(n + 1) * 256] + bytes(256))[:256]
        assert blk[32 + 256:508] == bytes(476 - 256)
    assert uf2.read(out) == (0x10000000, image + bytes(256 - 4))


def test_blocks_in_any_order_read_back_and_damage_is_refused():
    image = os.urandom(2000)
    out = uf2.write(image)
    blocks = [out[i:i + 512] for i in range(0, len(out), 512)]
    base, back = uf2.read(b"".join(reversed(blocks)))
    assert base == 0x10000000 and back[:2000] == image
    with pytest.raises(uf2.UF2Error):
        uf2.read(b"".join(blocks[:-1]))  # a block missing
    bad = bytearray(out)
    bad[0] ^= 1
    with pytest.raises(uf2.UF2Error):
        uf2.read(bytes(bad))
    with pytest.raises(uf2.UF2Error):
        uf2.read(uf2.write(image, family=0x12345678))  # another chip's file


@pytest.mark.parametrize("name", ["rp2040-stock", "buoy_pico", "rp2040-full"])
def test_the_built_images_start_with_the_boot_stage2_and_fit_the_firmware_region(name):
    path = os.path.join(ROOT, "build", "firmware", name + ".uf2")
    if not os.path.exists(path):
        pytest.skip("%s.uf2 is not built: run `make firmware` (tools/firmware.py build)" % name)
    with open(path, "rb") as f:
        base, image = uf2.read(f.read())
    assert base == 0x10000000
    # the boot ROM checks the 252-byte second stage against the CRC-32 in
    # its last word (polynomial 0x04c11db7, not reflected, seed 0xffffffff)
    crc = 0xFFFFFFFF
    for b in image[:252]:
        crc ^= b << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7 if crc & 0x80000000 else crc << 1) & 0xFFFFFFFF
    assert struct.unpack_from("<I", image, 252)[0] == crc
    # RPI_PICO keeps the first 640 KiB of its 2 MiB for the firmware; the
    # littlefs filesystem starts after it
    assert len(image) <= 640 * 1024
