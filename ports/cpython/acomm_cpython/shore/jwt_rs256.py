# JSON Web Tokens signed with RS256 (RSASSA-PKCS1-v1_5 with SHA-256, RFC
# 7515/7518, RFC 8017 section 8.2), in pure Python: no package to install
# on a shore server for the one signature RockBLOCK puts on each MO POST.
#
# Keys come as PEM: a public key as SubjectPublicKeyInfo ("PUBLIC KEY") or
# PKCS#1 ("RSA PUBLIC KEY"); a private key (only the gateway emulator signs)
# as PKCS#1 ("RSA PRIVATE KEY") or PKCS#8 ("PRIVATE KEY"). A tiny DER reader
# takes the few ASN.1 shapes these use and refuses anything else.

import base64
import hashlib
import hmac
import json

# DER of DigestInfo's prefix for SHA-256 (RFC 8017 section 9.2, note 1)
_SHA256_PREFIX = bytes.fromhex("3031300d060960864801650304020105000420")
_RSA_OID = bytes.fromhex("2a864886f70d010101")  # 1.2.840.113549.1.1.1 rsaEncryption
_MAX_DER = 1 << 14  # a 4096-bit key is far smaller; bounds what a bad file costs


class JwtError(ValueError):
    """A token or key refused; .reason is short and fit for a counter."""

    def __init__(self, reason):
        ValueError.__init__(self, reason)
        self.reason = reason


def _tlv(b, i):
    # -> (tag, start of content, end of content)
    if i + 2 > len(b):
        raise JwtError("bad key")
    tag, n = b[i], b[i + 1]
    i += 2
    if n & 0x80:
        k = n & 0x7F
        if not 1 <= k <= 3 or i + k > len(b):
            raise JwtError("bad key")
        n = int.from_bytes(b[i:i + k], "big")
        i += k
    if i + n > len(b):
        raise JwtError("bad key")
    return tag, i, i + n


def _children(b, s, e):
    # the elements (tag, start, end) one after another in b[s:e]
    out = []
    while s < e:
        out.append(_tlv(b, s))
        s = out[-1][2]
    return out


def _seq(b, s, e, tag=0x30):
    # the children of the one element that fills b[s:e]
    t, cs, ce = _tlv(b, s)
    if t != tag or ce != e:
        raise JwtError("bad key")
    return _children(b, cs, ce)


def _ints(b, items):
    if any(t != 0x02 for t, _, _ in items):
        raise JwtError("bad key")
    return [int.from_bytes(b[s:e], "big") for _, s, e in items]


def _pem(text):
    # -> (label, DER bytes)
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    if len(lines) < 3 or not lines[0].startswith("-----BEGIN ") or not lines[-1].startswith("-----END "):
        raise JwtError("not a PEM key")
    label = lines[0][11:].rstrip("-")
    try:
        der = base64.b64decode("".join(lines[1:-1]), validate=True)
    except ValueError:
        raise JwtError("not a PEM key") from None
    if len(der) > _MAX_DER:
        raise JwtError("bad key")
    return label, der


def public_key(pem):
    """A PEM public key (SubjectPublicKeyInfo or PKCS#1) -> (n, e); JwtError when it is not an RSA key."""
    label, der = _pem(pem)
    if label == "RSA PUBLIC KEY":
        items = _seq(der, 0, len(der))
    elif label == "PUBLIC KEY":
        spki = _seq(der, 0, len(der))
        if len(spki) != 2 or spki[0][0] != 0x30 or spki[1][0] != 0x03:
            raise JwtError("not an RSA key")
        alg = _children(der, spki[0][1], spki[0][2])
        if not alg or alg[0][0] != 0x06 or der[alg[0][1]:alg[0][2]] != _RSA_OID:
            raise JwtError("not an RSA key")
        # the BIT STRING's first byte counts unused bits (0), then RSAPublicKey
        if der[spki[1][1]] != 0:
            raise JwtError("bad key")
        items = _seq(der, spki[1][1] + 1, spki[1][2])
    else:
        raise JwtError("not a public key")
    n, e = _ints(der, items)[:2] if len(items) == 2 else (None, None)
    if n is None or n.bit_length() < 1024 or e < 3:
        raise JwtError("bad key")
    return n, e


def private_key(pem):
    """A PEM private key (PKCS#1 or PKCS#8) -> (n, e, d)."""
    label, der = _pem(pem)
    if label not in ("PRIVATE KEY", "RSA PRIVATE KEY"):
        raise JwtError("not a private key")
    top = _seq(der, 0, len(der))
    if label == "PRIVATE KEY":
        # PKCS#8: version, algorithm, then the PKCS#1 key in an OCTET STRING
        if len(top) < 3 or top[2][0] != 0x04:
            raise JwtError("bad key")
        der = der[top[2][1]:top[2][2]]
    v = _ints(der, _seq(der, 0, len(der)))
    if len(v) < 4:
        raise JwtError("bad key")
    return v[1], v[2], v[3]


def public_pem(n, e):
    """(n, e) -> a PKCS#1 "RSA PUBLIC KEY" PEM text."""
    def der_int(x):
        b = x.to_bytes(x.bit_length() // 8 + 1, "big")
        return _der(0x02, b)

    body = base64.b64encode(_der(0x30, der_int(n) + der_int(e))).decode()
    lines = [body[i:i + 64] for i in range(0, len(body), 64)]
    return "-----BEGIN RSA PUBLIC KEY-----\n%s\n-----END RSA PUBLIC KEY-----\n" % "\n".join(lines)


def _der(tag, content):
    n = len(content)
    if n < 0x80:
        return bytes([tag, n]) + content
    nb = n.to_bytes((n.bit_length() + 7) // 8, "big")
    return bytes([tag, 0x80 | len(nb)]) + nb + content


def _encoded(msg, k):
    # EMSA-PKCS1-v1_5 (RFC 8017 section 9.2) of SHA-256(msg) in k bytes
    t = _SHA256_PREFIX + hashlib.sha256(msg).digest()
    if k < len(t) + 11:
        raise JwtError("key too small")
    return b"\x00\x01" + b"\xff" * (k - len(t) - 3) + b"\x00" + t


def verify(msg, sig, key):
    """True when sig is msg's RS256 signature under key (n, e); the comparison's time does not depend on where it differs."""
    n, e = key
    k = (n.bit_length() + 7) // 8
    if len(sig) != k:
        return False
    s = int.from_bytes(sig, "big")
    if s >= n:
        return False
    em = pow(s, e, n).to_bytes(k, "big")
    return hmac.compare_digest(em, _encoded(msg, k))


def sign(msg, key):
    """msg's RS256 signature under the private key (n, e, d)."""
    n, _, d = key
    k = (n.bit_length() + 7) // 8
    return pow(int.from_bytes(_encoded(msg, k), "big"), d, n).to_bytes(k, "big")


def _b64u(b):
    return base64.urlsafe_b64encode(b).rstrip(b"=").decode("ascii")


def _unb64u(s):
    if not s or any(c not in "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_" for c in s):
        raise JwtError("malformed token")
    try:
        return base64.urlsafe_b64decode(s + "=" * (-len(s) % 4))
    except ValueError:
        raise JwtError("malformed token") from None


def encode(claims, key):
    """A compact JWT of the claims (a dict) signed RS256 with the private key (n, e, d).

    The header is {"alg":"RS256"} alone, as Rock7's tokens have it (decode() asks no more)."""
    head = _b64u(json.dumps({"alg": "RS256"}, separators=(",", ":")).encode())
    body = _b64u(json.dumps(claims, separators=(",", ":")).encode())
    signing = (head + "." + body).encode("ascii")
    return head + "." + body + "." + _b64u(sign(signing, key))


def decode(token, key, max_len=8192):
    """The claims of a compact JWT whose RS256 signature verifies under key (n, e); JwtError otherwise.

    Reasons: "malformed token", "not RS256" (any other alg, "none" included), "bad signature"."""
    if not isinstance(token, str) or len(token) > max_len or token.count(".") != 2:
        raise JwtError("malformed token")
    h, b, s = token.split(".")
    try:
        head = json.loads(_unb64u(h))
        claims = json.loads(_unb64u(b))
    except (ValueError, RecursionError):  # deep nesting in 8 kB of JSON
        raise JwtError("malformed token") from None
    if not isinstance(head, dict) or not isinstance(claims, dict):
        raise JwtError("malformed token")
    if head.get("alg") != "RS256":
        raise JwtError("not RS256")
    if not verify((h + "." + b).encode("ascii"), _unb64u(s), key):
        raise JwtError("bad signature")
    return claims
