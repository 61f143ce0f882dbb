# Which received messages need a valid authentication tag.
#
# With a network key (acomm.frame.auth), messages that move a vehicle or change
# its mission are carried out only when the frame (or every fragment of the
# packet) that brought them verified. A Guard holds checks, each a
# function(payload) -> True when the payload holds such a command; a
# payload that no check claims passes unauthenticated, so a node keeps
# hearing status and chat from nodes that have no key.
#
# The checks are the application's policy, given to the node with its key
# (Node.set_auth): acomm.apps.policy.commands() builds the seed catalogs'
# set. With no checks, only key commands and (strict mode) control frames
# need a tag.
#
# Strict mode (the default with a key): besides commands, no frame that
# changes link or transport state is taken on the word of a frame without
# a valid tag: link ACKs, modem replies (REPLY), adverts (and the node id
# and period they claim), and the transport's SACKs of every kind, polls
# and probes; an unsealed fragment may neither join nor displace a sealed
# transfer, unsealed transfers hold at most UNSEALED_RX reassemblies, and
# the transport never answers one (no SACK, no refusal goes out for it);
# and only sealed frames make a node available. What is left (DATA, and
# packets of unsealed fragments) is delivered marked unauthenticated.
# Each refusal is counted in `refused`, by kind. Open mode (strict=False)
# is the behaviour before strict mode: only commands need a tag.

from ..frame.auth import KEY_CMD
from ..errors import AcommError
from ..frame import ACK, ADVERT, CONTROL, REPLY, SEGMENT

UNSEALED_RX = 2  # reassemblies unsealed fragments may hold at a time (of the transport's 8)
_SACK_BIT = 8  # acomm.transport.segment: K, in the frame's sequence field


class Guard:
    REFUSED = "command without a valid authentication tag"  # EV_REFUSED's reason

    def __init__(self, checks, strict=True):
        self.checks = tuple(checks)
        self.strict = strict
        self.refused = {}  # kind -> unsealed frames refused in strict mode

    def count(self, kind):
        self.refused[kind] = self.refused.get(kind, 0) + 1

    def refuses_frame(self, f):
        """Strict mode, an unsealed frame at the link: True (and counted) when
        it is a control frame (ACK, ADVERT, REPLY, route control, a SACK or a bare poll)."""
        t = f.ftype
        if t == ACK:
            kind = "ack"
        elif t == ADVERT:
            kind = "advert"
        elif t == REPLY:
            kind = "reply"
        elif t == CONTROL:
            kind = "route"  # a forged route request, reply or error would steer traffic
        elif t == SEGMENT and f.seq & _SACK_BIT:
            kind = "sack"
        elif t == SEGMENT and len(f.payload) <= 1:
            kind = "poll"  # a bare poll or a lane probe: it asks for a SACK
        else:
            return False
        self.count(kind)
        return True

    def admits_segment(self, rx, key, s, authed):
        """Strict mode, a segment at the transport (rx: its reassemblies,
        key: this one's). -> 0 refused (and counted), 1 taken, 2 taken
        quietly: an unsealed fragment, which gets no SACK."""
        r = rx.get(key)
        if authed:
            if r is not None and r.unauthed:
                del rx[key]  # a sealed fragment starts its lane afresh
            return 1
        if s.is_sack:
            kind = "sack"
        elif not s.payload:
            kind = "poll"
        elif r is not None:
            if r.unauthed:
                return 2
            kind = "fragment"  # a sealed transfer's lane
        else:
            n = 0
            for k in rx:
                if rx[k].unauthed:
                    n += 1
            if n < UNSEALED_RX:
                return 2
            kind = "flood"
        self.count(kind)
        return 0

    def admits(self, payload, authed, auth):
        # -> whether the payload may be passed on: not a command, or a
        # command that verified, whose counter then goes to the file before
        # it is carried out (a restart cannot make a recording of it fresh)
        if not self.is_command(payload):
            return True
        if authed:
            auth.commit()
            auth.key_command(payload)  # a key rotation step is carried out here
        return authed

    def is_command(self, payload):
        if payload[:2] == KEY_CMD:
            return True
        for check in self.checks:
            try:
                if check(payload):
                    return True
            except AcommError:
                pass  # not this catalog's message
        return False
