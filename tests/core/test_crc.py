from acomm import frame
from acomm.codec.crc import crc16, crc16_pure, nmea_xor
from acomm.errors import DecodeError
from acomm.prng import Prng


def test_check_value():
    assert crc16(b"123456789") == 0xBB3D
    assert crc16_pure(b"123456789") == 0xBB3D


def test_empty_and_initial():
    assert crc16(b"") == 0
    assert crc16(b"", 0x1234) == 0x1234


def test_incremental_equals_whole():
    rng = Prng(7)
    data = rng.bytes(200)
    for cut in (0, 1, 17, 100, 199, 200):
        assert crc16(data[cut:], crc16(data[:cut])) == crc16(data)


def test_fast_matches_pure_on_all_kinds_of_buffer():
    rng = Prng(3)
    for n in (1, 2, 31, 64, 257):
        d = rng.bytes(n)
        want = crc16_pure(d)
        assert crc16(d) == want
        assert crc16(bytearray(d)) == want
        assert crc16(memoryview(d)) == want
        assert crc16(memoryview(b"xx" + d)[2:]) == want


def test_imc_table_entry():
    # ref/imc.md: reflected table, entry [1] = 0xC0C1
    from acomm.codec._crc16_table import TABLE_LE

    assert TABLE_LE[2] | TABLE_LE[3] << 8 == 0xC0C1


def test_the_written_out_table_is_the_polynomials():
    # the table is a constant in the source (it stays in a board's flash):
    # every entry must be what polynomial 0xA001 gives
    from acomm.codec._crc16_table import TABLE_LE

    assert len(TABLE_LE) == 512
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ 0xA001 if c & 1 else c >> 1
        assert TABLE_LE[2 * i] | TABLE_LE[2 * i + 1] << 8 == c, i


def test_the_pure_crc_agrees_with_the_one_in_use():
    # crc16_pure is what a board runs when its modules load from flash (no
    # viper): on MicroPython its nibble table, on CPython the byte table;
    # crc16 may be the viper twin. Check value, every byte value, chaining.
    from acomm.codec.crc import crc16_pure

    assert crc16_pure(b"123456789") == 0xBB3D
    data = bytes(range(256)) + b"\x00\xff" * 40
    assert crc16_pure(data) == crc16(data)
    assert crc16_pure(data[100:], crc16_pure(data[:100])) == crc16(data)
    for b in range(256):
        assert crc16_pure(bytes((b,)), 0x1234) == crc16(bytes((b,)), 0x1234), b


def test_nmea_xor():
    # "$CCCFQ,SRC" body xor
    assert nmea_xor(b"") == 0
    assert nmea_xor(b"AB") == 0x41 ^ 0x42


def _frame32():
    payload = Prng(11).bytes(32 - frame.RAW_OVERHEAD_SHORT)
    return bytearray(frame.encode_raw(frame.Frame(frame.DATA, 3, 5, 9, payload)))


def _detected(buf):
    try:
        frame.check_raw(buf)
    except DecodeError:
        return True
    return False


def test_every_1_and_2_bit_error_in_32_byte_frame_is_detected():
    buf = _frame32()
    assert len(buf) == 32
    assert not _detected(buf)
    nbits = len(buf) * 8
    missed = 0
    checked = 0
    for i in range(nbits):
        buf[i >> 3] ^= 0x80 >> (i & 7)
        if not _detected(buf):
            missed += 1
        checked += 1
        for j in range(i + 1, nbits):
            buf[j >> 3] ^= 0x80 >> (j & 7)
            if not _detected(buf):
                missed += 1
            checked += 1
            buf[j >> 3] ^= 0x80 >> (j & 7)
        buf[i >> 3] ^= 0x80 >> (i & 7)
    assert checked == 256 + 256 * 255 // 2
    assert missed == 0
    assert not _detected(buf)


def test_sampled_3_bit_errors_are_detected():
    buf = _frame32()
    rng = Prng(5)
    nbits = len(buf) * 8
    for _ in range(3000):
        a = rng.below(nbits)
        b = rng.below(nbits)
        c = rng.below(nbits)
        if a == b or b == c or a == c:
            continue
        for p in (a, b, c):
            buf[p >> 3] ^= 0x80 >> (p & 7)
        assert _detected(buf)
        for p in (a, b, c):
            buf[p >> 3] ^= 0x80 >> (p & 7)


def test_sampled_bursts_up_to_16_bits_are_detected():
    buf = _frame32()
    rng = Prng(9)
    nbits = len(buf) * 8
    for _ in range(3000):
        length = rng.range(1, 16)
        start = rng.below(nbits - length + 1)
        # a burst: first and last bit flipped, the ones between at random
        pattern = [True] + [rng.chance(0.5) for _ in range(length - 2)] + ([True] if length > 1 else [])
        for k in range(length):
            if pattern[k]:
                p = start + k
                buf[p >> 3] ^= 0x80 >> (p & 7)
        assert _detected(buf)
        for k in range(length):
            if pattern[k]:
                p = start + k
                buf[p >> 3] ^= 0x80 >> (p & 7)
    assert not _detected(buf)
