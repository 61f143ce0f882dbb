# The real modems a CPython node can drive, and how `--modem` names them.
#
# The modems come from the one registry of the core's sans-IO drivers
# (acomm.drivers.registry, never the simulator's), which the boards build
# with too, so a topside node and a board drive a modem with the same class.
# Used by `acomm node`, `acomm run`, `acomm bridge imc` and the quickstart.
#
#   KIND:DEVICE[:BAUD]         a serial port: seatrac:/dev/ttyUSB0,
#                              iridium:/dev/ttyUSB1:19200
#   KIND:tcp://HOST:PORT       a modem on Ethernet (EvoLogics: port 9200)
#   KIND:socket://HOST:PORT, KIND:rfc2217://HOST:PORT
#                              a modem behind a serial server (pyserial URL)
#
# Errors come in two kinds, so that a command line can tell a typing
# mistake (ModemSpecError, a usage error) from a device that is missing,
# busy or silent (ModemError, at run time).
#
# Below add_modem_link, what the command lines (acomm_cpython.cli) and the
# libraries' users share: option texts (parse_value, parse_options, hostport,
# keyval, add_known), the network key file (load_key), the persistent store
# (open_store) and the SIGTERM handler (interrupt).

from acomm.errors import AcommError
from acomm.drivers.registry import MODEMS

# kind -> (driver module, class, default baud, medium, whether the driver
# takes the modem's address as its first argument)
DRIVERS = dict((m[0], ("acomm.drivers." + m[0],) + m[1:]) for m in MODEMS)
# the IMC bridge called the SMS modem "gsm" before this table existed
ALIASES = {"gsm": "sms"}

_URL_SCHEMES = ("socket://", "rfc2217://", "loop://", "spy://")


class ModemSpecError(AcommError):
    """A --modem text that does not parse (a usage error)."""


class ModemError(AcommError):
    """A modem that cannot be opened or does not answer (a run-time error)."""


def parse_spec(spec):
    """'KIND:WHERE' -> (kind, where, baud or None); ModemSpecError names what is wrong.

    WHERE is a device path (with an optional ':BAUD'), tcp://HOST:PORT or a
    pyserial URL."""
    kind, sep, where = spec.partition(":")
    kind = ALIASES.get(kind, kind)
    if kind not in DRIVERS:
        raise ModemSpecError("--modem %r: unknown modem kind %r (one of %s)" % (spec, kind, ", ".join(sorted(DRIVERS))))
    if not sep or not where:
        raise ModemSpecError("--modem %r: give KIND:DEVICE[:BAUD] or KIND:tcp://HOST:PORT" % spec)
    if where.startswith("tcp://") or where.startswith("tcp:"):
        host, _, port = where.split(":", 1)[1].lstrip("/").rpartition(":")
        if not host or not port.isdigit() or not 0 < int(port) < 65536:
            raise ModemSpecError("--modem %r: give tcp://HOST:PORT" % spec)
        return kind, "tcp://%s:%s" % (host, port), None
    if where.startswith(_URL_SCHEMES):
        return kind, where, None
    dev, sep, baud = where.rpartition(":")
    if sep and baud.isdigit():
        if not 300 <= int(baud) <= 4000000:
            raise ModemSpecError("--modem %r: baud %s outside 300..4000000" % (spec, baud))
        return kind, dev, int(baud)
    return kind, where, None


def make_driver(kind, address, **options):
    """A new sans-IO driver of that kind for the modem at `address` (the node id, usually)."""
    mod, cls, baud, _, addressed = DRIVERS[ALIASES.get(kind, kind)]
    klass = getattr(__import__(mod, None, None, [cls]), cls)
    if addressed:
        return klass(address, **options)
    options.setdefault("baud", baud)
    return klass(**options)


def open_stream(kind, where, baud=None):
    """The byte stream to the modem (SerialStream or TcpStream); ModemError when it cannot be opened."""
    from .streams import SerialStream, TcpStream

    if where.startswith("tcp://"):
        host, _, port = where[6:].rpartition(":")
        return TcpStream(host, int(port))
    import serial

    if baud is None:
        baud = DRIVERS[kind][2]
    try:
        if where.startswith(_URL_SCHEMES):
            return SerialStream(serial.serial_for_url(where, baud, timeout=0))
        # exclusive: a second program on the same modem would interleave
        # its commands with ours
        return SerialStream(serial.Serial(where, baud, timeout=0, exclusive=True))
    except (OSError, ValueError) as e:
        raise ModemError("cannot open %s: %s" % (where, _reason(e)))


def _reason(e):
    # pyserial wraps the OS error in its own text ("[Errno 2] could not open
    # port X: [Errno 2] No such file or directory: 'X'"): keep the cause
    inner = e.args[1] if len(e.args) > 1 and isinstance(e.args[1], str) else None
    if inner is None and e.args and isinstance(e.args[0], str):
        inner = e.args[0]
    text = inner or str(e)
    if "could not exclusively lock" in text or "Resource temporarily unavailable" in text:
        return "busy (another program has it open)"
    if "No such file or directory" in text:
        return "no such device"
    if "Permission denied" in text:
        return "permission denied (are you in the dialout group?)"
    return text


class StartWatch:
    """Whether a driver finished its start-up: wraps its take_events() to see EV_DRIVER_UP.

    Drivers without a start-up (transparent) count as up at once."""

    def __init__(self, driver):
        from acomm.events import EV_DRIVER_UP

        self.up = not hasattr(driver, "config")
        take = driver.take_events

        def watched():
            evs = take()
            for ev in evs:
                if ev[0] == EV_DRIVER_UP:
                    self.up = True
            return evs

        driver.take_events = watched


def add_modem_link(node, spec, name=None, options=None, **link_options):
    """Opens the modem named by spec and adds its link to node.

    Returns (link name, stream, StartWatch). The link is named after the
    medium ("acoustic", "satellite", "acoustic-2" for a second one) unless
    `name` is given. ModemSpecError or ModemError when it cannot."""
    kind, where, baud = parse_spec(spec)
    medium = DRIVERS[kind][3]
    if name is None:
        name = medium if medium not in node.links else "%s-%d" % (medium, len(node.links) + 1)
    try:
        driver = make_driver(kind, node.node_id, **(options or {}))
    except TypeError as e:
        raise ModemSpecError("--modem %r: %s" % (spec, e))
    stream = open_stream(kind, where, baud)
    watch = StartWatch(driver)
    node.add_link(name, driver, stream, medium=medium, **link_options)
    return name, stream, watch


# --- what the command lines share: option texts, the key, the store -----------


def parse_value(text):
    """An option's value: int, float, true/false (yes/no, on/off), or the text itself."""
    low = text.lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text


def parse_options(pairs):
    """--option KEY=VALUE lines -> {key: parse_value(value)}; ValueError names a line without '='."""
    options = {}
    for kv in pairs:
        if "=" not in kv:
            raise ValueError("--option wants KEY=VALUE, got %r" % kv)
        k, v = kv.split("=", 1)
        options[k.strip()] = parse_value(v.strip())
    return options


def hostport(text, default_host="0.0.0.0"):
    """"HOST:PORT", ":PORT" or "PORT" -> (host, port)."""
    host, _, port = text.rpartition(":")
    return (host or default_host, int(port))


def keyval(text):
    """"KEY=VALUE" -> (key, value); ValueError without '='."""
    k, sep, v = text.partition("=")
    if not sep:
        raise ValueError("expected KEY=VALUE, got %r" % text)
    return k, v


def add_known(node, pairs):
    """--known NAME=ID lines: the node's names for other nodes; ValueError on a bad line."""
    for kv in pairs:
        k, v = keyval(kv)
        node.names.add(k, int(v))


def read_private(path, what="key file"):
    """The text of a file that only its owner may read or write (stripped); AcommError otherwise.

    As ssh does with a private key, a file that anyone but its owner may
    read or write is refused: the secret may already be out."""
    import os

    try:
        mode = os.stat(path).st_mode
    except OSError as e:
        raise AcommError("%s %s: %s" % (what, path, e.strerror or e))
    if mode & 0o077:
        raise AcommError("%s %s: permissions %04o are too open: others than its owner can use it, so the secret "
                         "may be known already; make it the owner's only (chmod 600 %s), or take a new one"
                         % (what, path, mode & 0o7777, path))
    try:
        with open(path) as f:
            return f.read().strip()
    except OSError as e:
        raise AcommError("%s %s: %s" % (what, path, e.strerror or e))


def load_key(path):
    """The network key in a file -> its bytes; AcommError naming the file and what is wrong.

    The key itself never appears in a message; the file must be its owner's only (read_private)."""
    text = read_private(path)
    try:
        key = bytes.fromhex(text)
    except ValueError:
        raise AcommError("key file %s: not hex digits" % path) from None
    if not 16 <= len(key) <= 64:
        raise AcommError("key file %s: %d bytes, the key must be 16 to 64" % (path, len(key)))
    return key


def open_store(path_dir, capacity=1 << 22, max_record=1024):
    """The transport's persistent store in folder path_dir (made when missing)."""
    import os

    from acomm.transport.store import Store

    os.makedirs(path_dir, exist_ok=True)
    return Store(os.path.join(path_dir, "acomm.store"), capacity_bytes=capacity, max_record=max_record)


def interrupt(signum, frame):
    """A signal handler (SIGTERM) that ends a command as Ctrl-C does, through its finally blocks."""
    raise KeyboardInterrupt
