# A file layer that fails as a full, read-only or broken filesystem does, for
# acomm.transport.store's opener: Store(path, opener=fs.open). Real files on
# both runtimes; the faults are the errors littlefs, FAT and Linux give.
#
#   fs = FaultFS(free=None)
#   fs.free = 100     writes may take 100 more bytes (None: no limit); the
#                     write that passes it writes what fits, then raises
#                     OSError(ENOSPC), as a full disk does (fs.short = True:
#                     returns the short count instead, as FAT does)
#   fs.refuse = 30    every open for writing raises OSError(30) (EROFS; 13
#                     EACCES), as a read-only mount or a file without write
#                     permission does, and with EROFS so does every write to
#                     a file already open; reading still works
#   fs.fail = 5       the next write raises OSError(5) (EIO), once
#   fs.writes, fs.bytes   write() calls that wrote, and the bytes they wrote

ENOSPC = 28
EROFS = 30
EACCES = 13
EIO = 5


class FaultFS:
    def __init__(self, free=None):
        self.free = free
        self.short = False
        self.refuse = None
        self.fail = None
        self.writes = 0
        self.bytes = 0

    def open(self, path, mode="rb"):
        """The file at path, opened with the builtin open, wrapped (FaultFile); OSError(refuse) for writing when set."""
        if self.refuse is not None and mode != "rb":
            raise OSError(self.refuse)
        return FaultFile(self, open(path, mode))


class FaultFile:
    # the real file f, whose writes go through the filesystem's faults; the
    # rest (seek, read, readinto, flush, truncate where the port has it,
    # fileno, close) is the real file's
    def __init__(self, fs, f):
        self.fs = fs
        self.f = f

    def write(self, b):
        fs = self.fs
        if fs.fail is not None:
            e, fs.fail = fs.fail, None
            raise OSError(e)
        if fs.refuse == EROFS:
            # a file system remounted read-only refuses the writes of files
            # already open too (a file without write permission does not)
            raise OSError(EROFS)
        n = len(b)
        if fs.free is not None and n > fs.free:
            n = fs.free  # what fits goes in first, as on a real disk
            fs.free = 0
            if n:
                self.f.write(b[:n])
                fs.bytes += n
            if fs.short:
                return n
            raise OSError(ENOSPC)
        self.f.write(b)
        fs.writes += 1
        fs.bytes += n
        if fs.free is not None:
            fs.free -= n
        return n

    def __getattr__(self, name):
        return getattr(self.f, name)
