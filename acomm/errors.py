# The one error hierarchy of acomm. Decoders raise only DecodeError (or a
# subclass), so a caller that feeds bytes from the sea needs a single except.


class AcommError(Exception):
    pass


class DecodeError(AcommError):
    # Bytes that do not form a valid object: truncated, wrong version,
    # lengths that lie, values out of range.
    pass


class CRCError(DecodeError):
    # A frame whose checksum does not match; a DecodeError so that generic
    # handlers drop it like any other damaged input.
    pass


class EncodeError(AcommError):
    # A value that cannot be represented: out of range, too long, too many
    # bits for the buffer. Raised instead of truncating silently (MicroPython's
    # struct would truncate).
    pass


class StoreError(AcommError):
    # The persistent store cannot do what was asked: the file is not a store,
    # the store is closed, a setting is out of range.
    pass


class StoreFull(StoreError):
    # put() would take the store past its capacity even after compaction.
    # The caller refuses the new packet; nothing already stored is dropped.
    pass


class AuthError(DecodeError):
    # A frame whose authentication tag does not verify, or whose counter was
    # already seen (a replay): dropped like any damaged frame, and counted.
    pass
