# The message sets of the seed documents. Each module defines CATALOG (an
# acomm.codec.message.Catalog) and its messages as module-level names:
#
#   caddy       seed 003: CADDY diver / vehicle navigation and interrogation
#   seaware     seed 002: Seaware AUV control set and its compact packet
#   rendezvous  seed 002: rendezvous protocol messages and roles
#   teleop      seed 004: six-axis thrust commands, heartbeat and failsafe
#
# Modules are imported by name when needed, so a board loads only the set it
# uses.
MODULES = ("caddy", "seaware", "rendezvous", "teleop")


def load(name):
    mod = __import__("acomm.catalog." + name, None, None, ("CATALOG",))
    return mod.CATALOG
