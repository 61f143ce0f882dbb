# `--iridium SERVICE:LISTEN[,KEY=VALUE...]`: a shore node's link to its
# buoys through the Iridium gateway, with no modem (acomm node, open_node):
#
#   directip:[HOST:]PORT[,mt=HOST:PORT][,imei=IMEI][,gateway=IP]...
#       MO messages by DirectIP to this listener; MT messages to the
#       gateway's MT DirectIP port; gateway=: only these addresses may connect
#   rockblock:[HOST:]PORT[,key=PEM][,mt=URL,credentials=FILE][,imei=IMEI][,max_age=S]
#       Rock7's MO POSTs to this HTTP listener, verified with the public key
#       Rock7 publishes (shore.rock7_key) or the one in the PEM file key=
#       (the emulator's TEST key under test); MT messages to the MT API at
#       URL (default Rock7's) as the user in FILE (username= and password=
#       lines, a file only its owner can read)
#
# imei: the buoy's IMEI (else the first MO message's, and MT waits for it).

from acomm.errors import AcommError

from ..modems import ModemSpecError, hostport
from .driver import ShoreDriver

SERVICES = ("directip", "rockblock")
# a shore link's defaults, as the buoy's satellite link: adverts once an hour (each costs a
# message), and two minutes for an ACK that comes back through a session and the gateway
LINK_OPTIONS = {"medium": "satellite", "advert_period_ms": 3600000, "ack_timeout_ms": 120000}
_KEYS = {"directip": ("mt", "imei", "gateway"), "rockblock": ("mt", "credentials", "key", "imei", "max_age")}


def parse_spec(text):
    """An --iridium text -> (service, (host, port), {key: value or [values] for gateway}); ModemSpecError."""
    service, sep, rest = text.partition(":")
    if service not in SERVICES or not sep or not rest:
        raise ModemSpecError("--iridium %r: want directip:[HOST:]PORT[,...] or rockblock:[HOST:]PORT[,...]" % text)
    parts = rest.split(",")
    try:
        listen = hostport(parts[0])
    except (AcommError, ValueError):
        raise ModemSpecError("--iridium %r: %r is not [HOST:]PORT" % (text, parts[0])) from None
    opts = {"gateway": []}
    for p in parts[1:]:
        k, eq, v = p.partition("=")
        if not eq or k not in _KEYS[service] or not v:
            raise ModemSpecError("--iridium %r: %r is not one of %s=VALUE" % (text, p, "/".join(_KEYS[service])))
        if k == "gateway":
            opts["gateway"].append(v)
        else:
            opts[k] = v
    if service == "rockblock":
        if "mt" in opts and "credentials" not in opts:
            raise ModemSpecError("--iridium %r: mt=URL needs credentials=FILE" % text)
    return service, listen, opts


def link_name(i):
    """The name of the i-th --iridium link (from 0): "satellite", then "satellite2", ..."""
    return "satellite" if i == 0 else "satellite%d" % (i + 1)


def add_shore_link(node, text, name="satellite", **link_options):
    """Adds a shore link to node for an --iridium text -> (link, port). ModemSpecError for a bad text,
    AcommError for a key or credentials file that cannot be used, OSError when the listener cannot bind."""
    service, listen, opts = parse_spec(text)
    driver = ShoreDriver(service, imei=opts.get("imei"))
    if service == "directip":
        from .directip_port import DirectIpShorePort

        mt = hostport(opts["mt"], "127.0.0.1") if "mt" in opts else None
        port = DirectIpShorePort(driver, listen, mt=mt, gateways=opts["gateway"] or None)
    else:
        from .rockblock import MT_URL, read_credentials
        from .rockblock_port import RockblockShorePort

        key = _rockblock_key(opts.get("key"))
        creds = read_credentials(opts["credentials"]) if "credentials" in opts else None
        mt_url = opts.get("mt", MT_URL) if creds else None
        try:
            max_age = float(opts.get("max_age", 300))
        except ValueError:
            raise ModemSpecError("--iridium %r: max_age wants seconds" % text) from None
        port = RockblockShorePort(driver, listen, key, mt_url=mt_url, credentials=creds, max_age_s=max_age)
    for k, v in LINK_OPTIONS.items():
        link_options.setdefault(k, v)
    try:
        link = node.add_link(name, driver, port, **link_options)
    except BaseException:
        port.close()
        raise
    return link, port


def _rockblock_key(path):
    # the JWT's verification key (n, e): Rock7's published one unless a PEM file is given
    from . import jwt_rs256

    if path is None:
        from .rock7_key import PUBLIC_PEM

        return jwt_rs256.public_key(PUBLIC_PEM)
    try:
        with open(path) as f:
            return jwt_rs256.public_key(f.read())
    except OSError as e:
        raise AcommError("key %s: %s" % (path, e.strerror or e))
    except jwt_rs256.JwtError as e:
        raise AcommError("key %s: %s" % (path, e.reason))
