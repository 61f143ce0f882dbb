# `acomm bench surface`: the buoy's packets to a real shore server and
# commands back, through the emulated Iridium gateway's shore services
# (surface_rig: diver --TCP--> buoy --SBD--> `acomm emulate`'s gateway -->
# shore node with no modem), on real sockets, HTTP and a pty.
#
#   shore_delivered_directip, shore_delivered_rockblock
#       diver reports that reached the shore's transport by DirectIP, and by
#       the RockBLOCK POST (of `reports` sent each way)
#   shore_lost
#       reports sent that did not arrive, both ways together (0)
#   shore_refused_forged_posts
#       forged MO POSTs (a signed POST's data changed, a signature altered,
#       none at all) the RockBLOCK shore refused with 401, of `forged` sent
#   shore_mt_round_trip_s
#       a packet from shore to the buoy (an MT message, fetched at the
#       session a ring alert starts) and its acknowledgement back (an MO
#       message): the median over both services, in emulated seconds (real
#       seconds x the emulator's time scale), so at the emulator's session
#       timing (8 s a session, 5 to 20 s through the network each way)
# quick: 2 reports and 1 command each way, 3 forged POSTs.

import tempfile

from .surface_rig import SurfaceRig, forge_posts

TIME_SCALE = 20.0


def _median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2] if xs else 0.0


def run(emit, quick=False):
    reports, commands, forged = (2, 1, 3) if quick else (10, 3, 12)
    delivered, trips, refused = {}, [], 0
    for service in ("directip", "rockblock"):
        with tempfile.TemporaryDirectory() as d:
            rig = SurfaceRig(d, service, time_scale=TIME_SCALE)
            try:
                got = 0
                for i in range(reports):
                    got += rig.report(b"diver report %d via %s" % (i, service.encode()), 60) is not None
                delivered[service] = got
                for i in range(commands):
                    t = rig.command(b"shore command %d" % i, 60)
                    if t is not None:
                        trips.append(t * TIME_SCALE)
                if service == "rockblock":
                    refused = forge_posts(rig.port.address, rig.host.stations[0].emu.imei, forged)
            finally:
                rig.close()
    emit("shore_delivered_directip", delivered["directip"], "packets of %d" % reports)
    emit("shore_delivered_rockblock", delivered["rockblock"], "packets of %d" % reports)
    emit("shore_lost", 2 * reports - delivered["directip"] - delivered["rockblock"], "packets")
    emit("shore_refused_forged_posts", refused, "posts of %d" % forged)
    emit("shore_mt_round_trip_s", round(_median(trips), 1), "s (emulated)")
