# MicroPython-only viper implementation of CRC-16/ARC; imported by acomm.codec.crc
# only on MicroPython, and only if the build has the viper emitter.
import micropython

from ._crc16_table import TABLE_LE


def make_crc16(table=TABLE_LE):
    @micropython.viper
    def _crc16(data, crc: int) -> int:
        t = ptr16(table)  # noqa: F821 (viper builtin)
        p = ptr8(data)  # noqa: F821
        n = int(len(data))
        c = crc
        for i in range(n):
            c = (c >> 8) ^ t[(c ^ p[i]) & 0xFF]
        return c

    def crc16(data, crc=0):
        # viper functions take no default arguments
        return _crc16(data, crc)

    return crc16
