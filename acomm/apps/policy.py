# The command policy of the seed catalogs: which received messages move a
# vehicle or change its mission, and so need a valid authentication tag when
# the node has a key (acomm.link.guard). Given to the node with its key:
#   node.set_auth(Auth(key), commands())
#
# commands() claims Seaware's start and stop mission and rendezvous on/off,
# teleop thrust, and CADDY diver commands (stop, come here, go up, ...: what
# a diver tells the vehicle). Each check decodes the payload as that
# catalog's message; bytes that do not decode are not that catalog's command.

from ..link.guard import Guard


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


def commands(strict=True):
    from ..catalog import caddy, seaware, teleop

    def seaware_body(payload):
        return seaware.decode_packet(payload)[2]

    return Guard((
        catalog_check(seaware.CATALOG, ("start_mission", "stop_mission", "rendezvous_on", "rendezvous_off"),
                      seaware_body),
        catalog_check(teleop.CATALOG, ("thrust",)),
        catalog_check(caddy.CATALOG, ("command",)),
    ), strict)
