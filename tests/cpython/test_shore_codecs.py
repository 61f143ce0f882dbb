# The shore's sans-IO codecs (acomm_cpython.shore): DirectIP messages both
# ways with every IE field, and what each refuses by name; RS256 JWTs in
# pure Python (a token the emulator's test key signed verifies, a tampered,
# unsigned or "alg: none" one does not; Rock7's published key is read and a
# token Rock7 published verifies under it); the RockBLOCK MO POST's checks
# (missing field, malformed hex, unsigned, forged, claims that differ from
# the form, stale, replayed) and the MT API's form and answers.
import struct
import time

import pytest

from acomm_cpython.emulate.rockblockgw import public_test_pem
from acomm_cpython.emulate.rock7_testkey import PRIVATE_PEM
from acomm_cpython.shore import directip as dip
from acomm_cpython.shore import jwt_rs256 as jwt
from acomm_cpython.shore import rockblock as rb
from acomm_cpython.shore.rock7_key import PUBLIC_PEM as ROCK7_PEM
from acomm_cpython.shore.seen import Replays

IMEI = "300234010000001"
PRIV = jwt.private_key(PRIVATE_PEM)
PUB = jwt.public_key(public_test_pem())
# the same public half as SubjectPublicKeyInfo, the form keys are usually published in
# (`openssl rsa -pubout` of the emulator's TEST key)
SPKI = """\
-----BEGIN PUBLIC KEY-----
MIIBIjANBgkqhkiG9w0BAQEFAAOCAQ8AMIIBCgKCAQEAms/oCg5Unv9DhAlxaJWH
VyFYSaK0+e/U679ecau2SZ1gKGAcImwJnmmQa3OkwxK54LcxDEcJ8Z96+mOkcD2R
PhLxKonqZokFZ0hCQRIV+3GcKE/g7y/vaZmZcwXN6pZVUksUJ9ICSQFWckY6NEzQ
wK8bHWSR5LbCAHIh+NpfqY0I86dsECFDM/vLKfpP3IZ/MvEJecI+AG2rIftiIU/F
n4vYS0YE3bMKx/6NtEKJOb+47S75Ck5I0bfxbDqWQFt/9F8X5xERl2Th/zX8Jz//
7cP6CbfXc8fo5pBmciDetLPvgqZ9tY5uxcV++dbheKpTqE8zye5EkbbCK+cNqbQ4
/QIDAQAB
-----END PUBLIC KEY-----
"""

# A token Rock7 signed: the JSON example on its push API page,
# https://docs.rock7.com/reference/push-api (read 2026-11-27). It verifies
# under the key Ground Control publishes for RockBLOCK's MO webhook
# (shore.rock7_key), so it shows what the real service's tokens ask of us.
ROCK7_EXAMPLE_JWT = (
    "eyJhbGciOiJSUzI1NiJ9.eyJpc3MiOiJSb2NrIDciLCJpYXQiOjE2Nzg3ODUzMDgsImFsdCI6IjAiLCJhdCI6IjIwMjMtMDMtMTR"
    "UMDk6MTA6MDFaIiwiYXZlcmFnZUNvZyI6IjMyOCIsImF2ZXJhZ2VTb2ciOiIwLjAiLCJiYXR0ZXJ5IjoiOTgiLCJjb2ciOiIzMjg"
    "iLCJkZXZpY2VfdHlwZSI6IkdSSUZGSU4iLCJpZCI6ImVKd2d6ZHBYVnhOUm5vcHJaZXdiV01EbFFHTFB2QWJrIiwiaW1laSI6IjM"
    "wMDQzNDA2MjkyOTU0MCIsImxhdCI6IjUxLjQ5NTQwIiwibG9uIjoiLTMuMTcwNDAiLCJtb21zbiI6IjcwMTU0ODcxIiwicG93ZXI"
    "iOiJ0cnVlIiwic2VyaWFsIjoiMTAwMDE1Iiwic29nIjoiMC4wIiwic291cmNlIjoiR1BTIiwidGVtcCI6IjAuMCIsInRyYW5zbWl"
    "0X3RpbWUiOiIyMDIzLTAzLTE0VDA5OjE1OjA0WiIsInRyYW5zcG9ydCI6IkdQUlMiLCJ0cmlnZ2VyIjoiQlVSU1QiLCJ0eEF0Ijo"
    "iMjAyMy0wMy0xNFQwOToxNTowNFoifQ.g4AMhUDwaK-WKaaITOKMtIu8lVtsEBfJ-00ytW-c0jyGUFxNW0259Dj9JcR34NaIai-y"
    "sSTVzqXBdROsZAiZS0oTSRum9l56JwZQTE0-Zx5yUUO8AOsUqXPjsSg2lSgsnSMTiQHXOzhydL9GIkmiEVdwANeaB24AuP45__zU"
    "wjhwniUfi-Z2RTG8J22GqnQ9Q_w9Z861A0Bos7LmJEymbmcLOiDDdzfYxvVWE6GSm2y8ypBZEqhI0byNphZ5adIFM19iyqng4MVp"
    "Qe0Uh9Jc49RR_IAjte3AMS4Y82lO76sM90Tu3-3Jwhj3Iq_NGpfd4735Bl-b5FR5oePP40mV3Q"
)


def _read(data, allowed=dip.MO_IES, chunk=1):
    r = dip.Reader(allowed)
    out = None
    for i in range(0, len(data), chunk):
        out = r.feed(data[i:i + chunk])
    return out, r


def test_an_mo_message_carries_every_field_and_reads_back_split_anywhere():
    msg = dip.encode_mo(123456, IMEI, 0, 23, 5, 1700000000, b"hello", (41.1496, -8.68, 4))
    # revision 1, overall length, then header (3 + 28), location (3 + 11), payload (3 + 5)
    assert msg[:3] == struct.pack(">BH", 1, 31 + 14 + 8)
    assert msg[3:6] == b"\x01\x00\x1c" and msg[6:10] == struct.pack(">I", 123456) and msg[10:25] == IMEI.encode()
    ies, r = _read(msg)
    mo = dip.decode_mo(ies)
    assert (mo["cdr"], mo["imei"], mo["status"], mo["momsn"], mo["mtmsn"], mo["time_s"], mo["payload"]) == \
        (123456, IMEI, 0, 23, 5, 1700000000, b"hello")
    lat, lon, cep = mo["location"]
    assert abs(lat - 41.1496) < 1e-4 and abs(lon + 8.68) < 1e-4 and cep == 4
    assert r.eof() is None
    assert dip.encode_mo_confirmation(True) == b"\x01\x00\x04\x05\x00\x01\x01"


def test_mt_messages_and_confirmations_both_ways():
    msg = dip.encode_mt(7, IMEI, b"cmd", flags=dip.FLUSH_MT_QUEUE, priority=2)
    mt = dip.decode_mt(_read(msg, dip.MT_IES, 5)[0])
    assert (mt["client_id"], mt["imei"], mt["flags"], mt["payload"], mt["priority"]) == (7, IMEI.encode(), 1, b"cmd", 2)
    conf = dip.encode_mt_confirmation(7, IMEI, 99, -5)
    assert len(conf) == 3 + 3 + 25
    assert dip.decode_mt_confirmation(_read(conf, (dip.MT_CONFIRMATION,))[0]) == (7, IMEI, 99, -5)


@pytest.mark.parametrize("bad, reason", [
    (b"\x02\x00\x00", "bad protocol revision"),
    (b"\x01\x00\x22" + b"\x01\x00\x1b" + b"\x00" * 31, "wrong IE length"),  # a 27-byte MO header
    (b"\x01\x00\x06" + b"\x09\x00\x03abc", "unknown IE"),
    (b"\x01\x00\x06" + b"\x02\x00\x09abc", "truncated IE"),
    (b"\x01\xff\xff", "too long"),
    (b"\x01\x00\x08" + b"\x02\x00\x02ab" + b"\x02\x00\x00", "duplicate IE"),
])
def test_each_bad_message_is_refused_by_name(bad, reason):
    with pytest.raises(dip.DirectIpError) as e:
        _read(bad, chunk=len(bad))
    assert e.value.reason == reason


def test_a_message_cut_short_is_truncated_and_one_without_header_is_refused():
    msg = dip.encode_mo(1, IMEI, 0, 1, 0, 0, b"x")
    ies, r = _read(msg[:-1], chunk=len(msg))
    assert ies is None and r.eof() == "truncated"
    with pytest.raises(dip.DirectIpError) as e:
        dip.decode_mo(dip.parse_ies(b"\x02\x00\x01x", dip.MO_IES))
    assert e.value.reason == "no MO header"


def test_rs256_tokens_verify_and_tampered_or_unsigned_ones_do_not():
    tok = jwt.encode({"imei": IMEI, "iat": 1}, PRIV)
    assert jwt.decode(tok, PUB) == {"imei": IMEI, "iat": 1}
    h, b, s = tok.split(".")
    forged = jwt._b64u(b'{"imei":"300234010000002","iat":1}')
    for bad, reason in ((h + "." + forged + "." + s, "bad signature"),
                        (h + "." + b + "." + s[:-4] + ("AAAA" if s[-4:] != "AAAA" else "BBBB"), "bad signature"),
                        (jwt._b64u(b'{"alg":"none"}') + "." + b + ".", "not RS256"),
                        (h + "." + b, "malformed token"), ("x.y.z", "malformed token")):
        with pytest.raises(jwt.JwtError) as e:
            jwt.decode(bad, PUB)
        assert e.value.reason == reason, bad
    assert jwt.public_key(SPKI) == PUB
    with pytest.raises(jwt.JwtError):
        jwt.public_key("-----BEGIN PUBLIC KEY-----\nAAAA\n-----END PUBLIC KEY-----")


def test_rock7s_published_key_is_read_and_verifies_a_token_rock7_signed():
    n, e = jwt.public_key(ROCK7_PEM)
    assert (n.bit_length(), e) == (2048, 65537)
    claims = jwt.decode(ROCK7_EXAMPLE_JWT, (n, e))
    # the claims check_mo() asks of a token are all there, in the service's own shape
    assert claims["iss"] == rb.ISSUER and isinstance(claims["iat"], int)
    assert isinstance(claims["imei"], str) and isinstance(claims["momsn"], str)
    with pytest.raises(jwt.JwtError) as err:
        jwt.decode(ROCK7_EXAMPLE_JWT, PUB)
    assert err.value.reason == "bad signature"
    # the emulator's tokens have the same header as Rock7's: {"alg": "RS256"} alone
    head = ROCK7_EXAMPLE_JWT.split(".")[0]
    assert jwt.encode({"iat": 1}, PRIV).split(".")[0] == head


def _fields(momsn=1, data=b"hi"):
    return {"imei": IMEI, "serial": "0000001", "momsn": str(momsn), "transmit_time": "26-11-27 10:00:00",
            "iridium_latitude": "41.1496", "iridium_longitude": "-8.6800", "iridium_cep": "4", "data": data.hex()}


def test_the_rockblock_post_is_checked_field_by_field():
    replays = Replays(2)
    good = rb.form(rb.mo_form(_fields(), PRIV))
    assert set(rb.MO_FIELDS) | {"JWT"} == set(good)
    mo = rb.check_mo(good, PUB, replays)
    assert (mo["imei"], mo["momsn"], mo["payload"]) == (IMEI, 1, b"hi")
    replays.add((IMEI, 1))

    def refused(fields, **kw):
        with pytest.raises(rb.RockblockError) as e:
            rb.check_mo(fields, PUB, replays, **kw)
        return e.value.reason, e.value.http

    assert refused(good) == ("replayed", 409)
    assert refused(dict(good, data="6g")) == ("malformed hex", 400)
    assert refused(dict((k, v) for k, v in good.items() if k != "momsn")) == ("missing field", 400)
    assert refused(dict(good, imei="12")) == ("malformed field", 400)
    unsigned = dict(good)
    del unsigned["JWT"]
    assert refused(unsigned) == ("unsigned", 401)
    other = rb.form(rb.mo_form(_fields(2, b"other"), PRIV))
    assert refused(dict(other, JWT=good["JWT"])) == ("claims differ", 401)
    stale = rb.form(rb.mo_form(_fields(3), PRIV, now_s=time.time() - 3600))
    assert refused(stale) == ("stale", 401)
    forged = dict(other, JWT=other["JWT"][:-6] + ("AAAAAA" if other["JWT"][-6:] != "AAAAAA" else "BBBBBB"))
    assert refused(forged) == ("bad signature", 401)
    for n in (5, 6, 7):
        replays.add((IMEI, n))
    assert not replays.seen((IMEI, 1)), "the oldest goes when the table is full"
    with pytest.raises(rb.RockblockError):
        rb.form(b"a=1&a=2")


def test_the_mt_api_form_and_answers():
    body = rb.form(rb.mt_form(IMEI, "user", "pw", b"\x01\x02", flush=True))
    assert body == {"imei": IMEI, "username": "user", "password": "pw", "data": "0102", "flush": "yes"}
    assert rb.parse_mt_answer(rb.mt_answer(True, 12345)) == (True, 12345)
    assert rb.parse_mt_answer(rb.mt_answer(False, 10)) == (False, "FAILED,10,Invalid login credentials")
    assert rb.parse_mt_answer(b"<html>")[0] is False
