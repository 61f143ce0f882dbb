# The RockBLOCK web service (Rock7, now Ground Control), sans-IO: the HTTP
# POST of form fields that delivers each MO message to the customer's
# endpoint, with a JWT that Rock7 signs (RS256), and the MT API's form and
# its one-line answers. docs/drivers-iridium.md has each field with its
# source; the pages are
#   MO: https://docs.groundcontrol.com/iot/rockblock/web-services/receiving-mo-message
#   MT: https://docs.groundcontrol.com/iot/rockblock/web-services/sending-mt-message
#   JWT claims: https://docs.rock7.com/reference/push-api (an example token)
#
# MO POST (application/x-www-form-urlencoded): imei, serial, momsn,
# transmit_time ("YY-MM-DD HH:MM:SS", UTC), iridium_latitude,
# iridium_longitude, iridium_cep, data (the payload in hex), JWT. Rock7's
# tokens carry the POST's fields as string claims plus "iss": "Rock 7" and
# "iat" (seconds), under the header {"alg": "RS256"} alone (no typ, no kid,
# no exp): that is all check_mo() asks of them. It takes a POST only when
# the JWT verifies, its claims repeat the form's imei, momsn and data, it is
# no older than max_age_s, and (imei, momsn) has not been taken before
# (shore.seen.Replays, a bounded table).
#
# MT API: POST imei, username, password, data (hex) [, flush=yes: empty the
# IMEI's MT queue first] to https://rockblock.rock7.com/rockblock/MT; the
# answer is "OK,<mtId>" or "FAILED,<code>,<text>" (MT_FAILURES, the page's
# table).

import time
from urllib.parse import parse_qs, urlencode

from . import jwt_rs256

MT_URL = "https://rockblock.rock7.com/rockblock/MT"
ISSUER = "Rock 7"  # the "iss" claim of Rock7's tokens (the push API page's example)
MO_FIELDS = ("imei", "serial", "momsn", "transmit_time", "iridium_latitude", "iridium_longitude", "iridium_cep",
             "data")
MT_FAILURES = {
    10: "Invalid login credentials",
    11: "No RockBLOCK with this IMEI found on your account",
    12: "RockBLOCK has no line rental",
    13: "Your account has insufficient credit",
    14: "Could not decode hex data",
    15: "Data too long",
    16: "No data",
    99: "System Error",
}
MAX_FORM = 8192  # an MO POST carries at most 340 bytes (680 hex digits) and a JWT of about 1.5 kB


class RockblockError(ValueError):
    """A request refused: .reason (a counter's name) and .http (the status to answer)."""

    def __init__(self, reason, http=400):
        ValueError.__init__(self, reason)
        self.reason = reason
        self.http = http


def form(body, max_len=MAX_FORM):
    """A urlencoded body -> dict of single values; RockblockError for a malformed one."""
    if len(body) > max_len:
        raise RockblockError("too long", 413)
    try:
        q = parse_qs(body.decode("ascii"), keep_blank_values=True, strict_parsing=bool(body), max_num_fields=32)
    except (UnicodeDecodeError, ValueError):
        raise RockblockError("malformed form") from None
    if any(len(v) != 1 for v in q.values()):
        raise RockblockError("malformed form")
    return dict((k, v[0]) for k, v in q.items())


def _hex(s, reason):
    try:
        if len(s) % 2:
            raise ValueError
        return bytes.fromhex(s)
    except ValueError:
        raise RockblockError(reason) from None


def check_mo(fields, key, replays, now_s=None, max_age_s=300, mo_max=340):
    """An MO POST's fields -> dict imei, momsn, payload, fields; RockblockError(reason, http) when refused.

    Reasons: "missing field", "malformed hex", "malformed field", "unsigned", "bad signature",
    "claims differ", "stale", "replayed". The pair is remembered only by take()."""
    for f in ("imei", "momsn", "data"):
        if f not in fields:
            raise RockblockError("missing field")
    payload = _hex(fields["data"], "malformed hex")
    imei, momsn = fields["imei"], fields["momsn"]
    if len(imei) != 15 or not imei.isdigit() or not momsn.isdigit() or int(momsn) > 65535 or not payload \
            or len(payload) > mo_max:
        raise RockblockError("malformed field")
    token = fields.get("JWT")
    if not token:
        raise RockblockError("unsigned", 401)
    try:
        claims = jwt_rs256.decode(token, key)
    except jwt_rs256.JwtError as e:
        raise RockblockError("bad signature" if e.reason in ("bad signature", "not RS256") else "unsigned", 401) \
            from None
    if any(str(claims.get(f)) != fields[f] for f in ("imei", "momsn", "data")) or claims.get("iss") != ISSUER:
        raise RockblockError("claims differ", 401)
    now_s = time.time() if now_s is None else now_s
    iat = claims.get("iat")
    if not isinstance(iat, (int, float)) or abs(now_s - iat) > max_age_s:
        raise RockblockError("stale", 401)
    if replays.seen((imei, int(momsn))):
        raise RockblockError("replayed", 409)
    return {"imei": imei, "momsn": int(momsn), "payload": payload, "fields": fields}


def mo_form(fields, key, now_s=None):
    """What Rock7 POSTs for one MO message: the fields (hex data included) and their JWT, urlencoded."""
    claims = dict(fields)
    claims["iat"] = int(time.time() if now_s is None else now_s)
    claims["iss"] = ISSUER
    body = dict(fields)
    body["JWT"] = jwt_rs256.encode(claims, key)
    return urlencode(body).encode("ascii")


def mt_form(imei, username, password, payload, flush=False):
    """The MT API's request body for one message."""
    f = {"imei": imei, "username": username, "password": password, "data": bytes(payload).hex()}
    if flush:
        f["flush"] = "yes"
    return urlencode(f).encode("ascii")


def mt_answer(ok, value):
    """The MT API's answer: ok -> "OK,<value>" (the message id); else "FAILED,<code>,<text>"."""
    if ok:
        return b"OK,%d" % value
    return ("FAILED,%d,%s" % (value, MT_FAILURES.get(value, "Error"))).encode("ascii")


def parse_mt_answer(text):
    """An MT API answer -> (True, message id) or (False, "FAILED,<code>,<text>" as the reason)."""
    t = text.decode("ascii", "replace").strip()
    if t.startswith("OK,") and t[3:].isdigit():
        return True, int(t[3:])
    if t.startswith("FAILED,"):
        return False, t[:200]
    return False, "unexpected answer %r" % t[:60]


def read_credentials(path):
    """(username, password) from a file of `username=...` and `password=...` lines that only its owner can read."""
    from ..modems import read_private

    vals = {}
    for line in read_private(path, "credentials file").splitlines():
        if "=" in line:
            k, v = line.split("=", 1)
            vals[k.strip()] = v.strip()
    if not vals.get("username") or "password" not in vals:
        from acomm.errors import AcommError

        raise AcommError("credentials file %s: needs username= and password= lines" % path)
    return vals["username"], vals["password"]
