# The shore end of the satellite link: a node with no modem that takes a
# buoy's Iridium SBD messages from the gateway and gives it MT messages back,
# by Iridium DirectIP (directip, directip_port) or by the RockBLOCK web
# service (rockblock, rockblock_port, with jwt_rs256 for its signature). The
# codecs are sans-IO; driver is the link driver both ports feed; spec parses
# `--iridium directip:...` / `rockblock:...`. docs/drivers-iridium.md.
