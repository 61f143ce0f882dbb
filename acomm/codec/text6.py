# The CADDY legacy 6-bit chat alphabet (seed 003 section 5): lower-case
# letters, digits, ". , ? !", space and newline, in that order, then END.
#
#   code  0..25  a..z
#   code 26..35  0..9
#   code 36..41  .  ,  ?  !  space  newline
#   code 42      END (the legacy "\0"): the text stopped before max_chars
#   code 43..63  reserved: DecodeError
#
# A diver tablet has no shift key and a few hundred bit/s: 42 symbols cost
# 6 bits each instead of 8 for ASCII. Upper case is not in the alphabet;
# clean() folds it before encoding.

import math

from ..compat import const
from ..errors import DecodeError
from ..errors import EncodeError
from .fields import Field, fail

ALPHABET = "abcdefghijklmnopqrstuvwxyz0123456789.,?! \n"
END = const(42)
_SYMBOLS = const(42)
_BAD = const(255)

# ord(char) -> code, 255 where the character is not in the alphabet
_CODE = bytearray(b"\xff" * 128)
for _i in range(len(ALPHABET)):
    _CODE[ord(ALPHABET[_i])] = _i
_CHAR = ALPHABET.encode()


def code_of(ch):
    o = ord(ch)
    return _CODE[o] if o < 128 else _BAD


def clean(s, repl="?"):
    # Folds s into the alphabet: lower case, anything else becomes repl.
    out = []
    for ch in s.lower():
        out.append(ch if code_of(ch) != _BAD else repl)
    return "".join(out)


class Text6(Field):
    def __init__(self, name, max_chars):
        self.name = name
        self.max_chars = max_chars
        self.max_bits = 6 * max_chars
        self.min_bits = 6 if max_chars else 0
        n = max_chars
        # log2(sum of 42**k for k in 0..n), without the huge integer
        self.limit_bits = n * math.log2(_SYMBOLS) + math.log2((1 - _SYMBOLS ** -(n + 1.0)) / (1 - 1.0 / _SYMBOLS))
        self._scratch = bytearray(max_chars)

    def encode(self, w, s):
        if not isinstance(s, str):
            raise fail(EncodeError, "%s is not a str" % type(s).__name__)
        n = len(s)
        if n > self.max_chars:
            raise fail(EncodeError, "%d characters, at most %d" % (n, self.max_chars))
        for i in range(n):
            c = code_of(s[i])
            if c == _BAD:
                raise fail(EncodeError, "character %r at %d is not in the 6-bit alphabet" % (s[i], i))
            w.write(c, 6)
        if n < self.max_chars:
            w.write(END, 6)

    def decode(self, r):
        buf = self._scratch
        n = 0
        while n < self.max_chars:
            c = r.read(6)
            if c >= _SYMBOLS:
                if c == END:
                    break
                raise fail(DecodeError, "reserved 6-bit code %d at %d" % (c, n))
            buf[n] = _CHAR[c]
            n += 1
        return bytes(buf[:n]).decode()
