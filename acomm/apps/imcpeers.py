# Who an IMC gateway talks to, sans-IO (docs/imc.md, "Gateway").
#
# DUNE's Discovery and UDP transports keep two tables, and so does this:
#   - systems: IMC id -> what its last Announce said (name, type, services),
#     fed by Announces whatever port they came in on. It is the resolver of
#     IMC names, and tells which IMC system is which acomm node: a gateway
#     announces "acomm://node/<id>/<name>", so gateways learn each other's
#     acomm identity without configuration.
#   - subscribers: where our publications (UamRxFrame, UamRxRange) go: the
#     static destinations, every "imc+udp://host:port/" service of a system
#     announced within the contact timeout, and every endpoint a valid IMC
#     packet came from within it (DUNE's contacts, so a plain UDP socket that
#     sent us anything hears what we publish for the next 30 s).
# Both tables are bounded; when full, the entry heard longest ago goes.
# Endpoints are (host, port) with host a dotted quad.

from ..compat import ticks_diff

ACOMM_NODE = "acomm://node/"  # + "<node id>/<acomm name>"
ACOMM_UID = "acomm://uid/"  # + a per-process token: our own announce looped back


class System:
    __slots__ = ("imc_id", "name", "sys_type", "services", "udp", "acomm", "heard", "stamp")

    def __init__(self, imc_id):
        self.imc_id = imc_id
        self.name = None
        self.sys_type = None
        self.services = ()
        self.udp = ()  # endpoints of its imc+udp services
        self.acomm = None  # (acomm node id, acomm name) when it announced one
        self.heard = None
        self.stamp = None


def parse_services(text):
    # -> (udp endpoints, acomm (id, name) or None, uid or None). Anything
    # that does not parse is skipped: an Announce is advice, not a contract.
    udp = []
    acomm = None
    uid = None
    for url in text.split(";"):
        url = url.strip()
        if url.startswith("imc+udp://"):
            hostport = url[len("imc+udp://"):].split("/", 1)[0]
            host, _, port = hostport.rpartition(":")
            try:
                p = int(port)
                parts = [int(x) for x in host.split(".")]
            except ValueError:
                continue
            if 0 < p < 65536 and len(parts) == 4 and all(0 <= x <= 255 for x in parts) and parts != [0, 0, 0, 0]:
                ep = (host, p)
                if ep not in udp:
                    udp.append(ep)
        elif url.startswith(ACOMM_NODE):
            nid, _, name = url[len(ACOMM_NODE):].partition("/")
            name = name.rstrip("/")
            try:
                n = int(nid)
            except ValueError:
                continue
            if 0 <= n <= 254 and name:
                acomm = (n, name)
        elif url.startswith(ACOMM_UID):
            uid = url[len(ACOMM_UID):]
    return udp[:8], acomm, uid


class ImcPeers:
    def __init__(self, own_id, uid, static=(), capacity=64, contacts=32, contact_timeout_ms=30000):
        self.own_id = own_id
        self.uid = uid
        self.static = list(static)
        self.capacity = capacity
        self.max_contacts = contacts
        self.timeout_ms = contact_timeout_ms
        self.systems = {}  # imc id -> System
        self.contacts = {}  # endpoint -> ticks last heard
        self.stats = {"announces": 0, "announce_dups": 0, "announce_own": 0, "systems_new": 0, "systems_dropped": 0,
                      "contacts_dropped": 0}

    # -- contacts --------------------------------------------------------------
    def heard(self, now, endpoint):
        c = self.contacts
        if endpoint not in c and len(c) >= self.max_contacts:
            self._forget_oldest_contact()
        c[endpoint] = now

    def _forget_oldest_contact(self):
        old = None
        for ep in self.contacts:
            if old is None or ticks_diff(self.contacts[ep], self.contacts[old]) < 0:
                old = ep
        del self.contacts[old]
        self.stats["contacts_dropped"] += 1

    def _fresh(self, now, t):
        return t is not None and ticks_diff(now, t) < self.timeout_ms

    def subscribers(self, now):
        out = list(self.static)
        for s in self.systems.values():
            if self._fresh(now, s.heard):
                for ep in s.udp:
                    if ep not in out:
                        out.append(ep)
        for ep in self.contacts:
            if self._fresh(now, self.contacts[ep]) and ep not in out:
                out.append(ep)
        return out

    # -- announces ---------------------------------------------------------------
    def on_announce(self, now, pkt):
        # -> the System it updated, or None for our own or a copy
        m = pkt.msg
        udp, acomm, uid = parse_services(m["services"])
        if pkt.src == self.own_id or (uid is not None and uid == self.uid):
            self.stats["announce_own"] += 1
            return None
        s = self.systems.get(pkt.src)
        if s is not None and s.stamp == pkt.timestamp and s.name == m["sys_name"]:
            # one announce comes by loopback, multicast and broadcast
            self.stats["announce_dups"] += 1
            return None
        if s is None:
            if len(self.systems) >= self.capacity:
                self._forget_oldest_system()
            s = self.systems[pkt.src] = System(pkt.src)
            self.stats["systems_new"] += 1
        self.stats["announces"] += 1
        s.name = m["sys_name"]
        s.sys_type = m["sys_type"]
        s.services = m["services"]
        s.udp = tuple(udp)
        s.acomm = acomm
        s.heard = now
        s.stamp = pkt.timestamp
        return s

    def _forget_oldest_system(self):
        old = None
        for k in self.systems:
            if old is None or ticks_diff(self.systems[k].heard, self.systems[old].heard) < 0:
                old = k
        del self.systems[old]
        self.stats["systems_dropped"] += 1

    def by_name(self, name):
        for s in self.systems.values():
            if s.name == name:
                return s
        return None

    def by_acomm_id(self, node_id):
        for s in self.systems.values():
            if s.acomm is not None and s.acomm[0] == node_id:
                return s
        return None
