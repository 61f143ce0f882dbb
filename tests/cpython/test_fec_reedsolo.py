# Cross-check of acomm.codec.fec against the reedsolo package (the `dev` extra
# installs it; skipped when it is not importable): same codewords for the
# same parameters, and each decoder repairs what the other encoded.
import random

import pytest

from acomm.codec.fec import ReedSolomon

reedsolo = pytest.importorskip("reedsolo")


@pytest.mark.parametrize("nsym", [1, 2, 4, 8, 10, 16, 32, 64])
def test_same_codewords_as_reedsolo(nsym):
    rnd = random.Random(nsym)
    ours = ReedSolomon(nsym)
    theirs = reedsolo.RSCodec(nsym)
    for _ in range(30):
        msg = bytes(rnd.randrange(256) for _ in range(rnd.randint(1, 255 - nsym)))  # reedsolo encodes b"" as b""
        cw = ours.encode(msg)
        assert cw == bytes(theirs.encode(msg))
        bad = bytearray(cw)
        for p in rnd.sample(range(len(cw)), rnd.randint(0, nsym // 2)):
            bad[p] ^= rnd.randrange(1, 256)
        assert ours.decode(bytes(bad)) == msg
        assert bytes(theirs.decode(bytes(bad))[0]) == msg
