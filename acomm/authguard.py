# Which received messages need a valid authentication tag.
#
# With a network key (acomm.auth), messages that move a vehicle or change
# its mission are carried out only when the frame (or every fragment of the
# packet) that brought them verified. A Guard holds checks, each a
# function(payload) -> True when the payload holds such a command; a
# payload that no check claims passes unauthenticated, so a node keeps
# hearing status and chat from nodes that have no key.
#
# commands() builds the default set from the seed catalogs: Seaware's start
# and stop mission and rendezvous on/off, teleop thrust, and CADDY diver
# commands (stop, come here, go up, ...: what a diver tells the vehicle).
# Each decodes the payload as that catalog's message; bytes that do not
# decode are not that catalog's command.

from .errors import AcommError


class Guard:
    REFUSED = "command without a valid authentication tag"  # EV_REFUSED's reason

    def __init__(self, checks):
        self.checks = tuple(checks)

    def admits(self, payload, authed, auth):
        # -> whether the payload may be passed on: not a command, or a
        # command that verified, whose counter then goes to the file before
        # it is carried out (a restart cannot make a recording of it fresh)
        if not self.is_command(payload):
            return True
        if authed:
            auth.commit()
        return authed

    def is_command(self, payload):
        for check in self.checks:
            try:
                if check(payload):
                    return True
            except AcommError:
                pass  # not this catalog's message
        return False


def catalog_check(catalog, names, unwrap=None):
    # -> check(payload): a message named in `names` is among those the
    # catalog unpacks from the payload (after unwrap, e.g. a packet header)
    names = tuple(names)  # a handful: a tuple, which every port has

    def check(payload):
        body = unwrap(payload) if unwrap is not None else payload
        for m, _ in catalog.unpack(body):
            if m.name in names:
                return True
        return False

    return check


def commands():
    from .catalog import caddy, seaware, teleop

    def seaware_body(payload):
        return seaware.decode_packet(payload)[2]

    return Guard((
        catalog_check(seaware.CATALOG, ("start_mission", "stop_mission", "rendezvous_on", "rendezvous_off"),
                      seaware_body),
        catalog_check(teleop.CATALOG, ("thrust",)),
        catalog_check(caddy.CATALOG, ("command",)),
    ))
