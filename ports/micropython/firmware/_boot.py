# Frozen into the qemu MPS2-AN385 firmware (tools/firmware.py) as _boot.py,
# which the patched main.c runs at every (soft) reset, as rp2's does: it
# gives the board what a Pico has, a littlefs filesystem at "/" and a ROMFS
# partition at /rom when one was loaded.
#
# The "flash" is 2 MiB of the board's PSRAM at 0x21400000, above the 4 MiB
# ROMFS partition (0x21000000) and below the heap-size word
# (0x21fffff8). It is outside the GC heap, so files survive a soft reset
# (mpremote's), not a restart of qemu. Blocks of 4096 bytes, as on a Pico.
import vfs


class _RamFlash:
    def __init__(self, addr, blocks, size=4096):
        import uctypes

        self.mem = memoryview(uctypes.bytearray_at(addr, blocks * size))
        self.size = size
        self.blocks = blocks

    def readblocks(self, n, buf, off=0):
        a = n * self.size + off
        buf[:] = self.mem[a : a + len(buf)]

    def writeblocks(self, n, buf, off=0):
        a = n * self.size + off
        self.mem[a : a + len(buf)] = buf

    def ioctl(self, op, arg):
        if op == 4:  # block count
            return self.blocks
        if op == 5:  # block size
            return self.size
        if op == 6:  # erase: RAM needs none
            return 0
        return None


def _mount():
    bdev = _RamFlash(0x21400000, 512)
    try:
        fs = vfs.VfsLfs2(bdev)
    except OSError:
        vfs.VfsLfs2.mkfs(bdev)
        fs = vfs.VfsLfs2(bdev)
    vfs.mount(fs, "/")
    import sys

    if "/lib" not in sys.path:  # where `acomm flash` puts modules, as on a Pico
        sys.path.append("/lib")
    try:
        # an image loaded with qemu's -device loader at the ROMFS partition;
        # v1.28's qemu port has VfsRom but no vfs.rom_ioctl, so the 4 MiB
        # partition is given as it lies in memory (VfsRom reads the image's
        # own length from its header, and refuses memory with no image)
        rom = getattr(vfs, "rom_ioctl", None)
        if rom is not None:
            part = rom(2, 0)
        else:
            import uctypes

            part = uctypes.bytearray_at(0x21000000, 0x400000)
        vfs.mount(vfs.VfsRom(part), "/rom")
        sys.path.insert(1, "/rom/lib")
        sys.path.insert(1, "/rom")
    except (OSError, ValueError, AttributeError):
        pass


_mount()
del _mount, _RamFlash, vfs
