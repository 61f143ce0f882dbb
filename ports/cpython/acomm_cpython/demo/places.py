# Where the demo happens: its three nodes, their acomm addresses and
# starting positions (x east, y north, depth; metres), and the acoustic
# channel's loss against range (metres, probability). A leaf, so that the
# benchmarks that put their own traffic on the demo's ocean (soak, attack)
# take the places without loading the mission.

BUOY, DIVER, AUV = "buoy", "diver", "auv"
ADDR = {BUOY: 1, DIVER: 2, AUV: 3}
START = {BUOY: (0.0, 0.0, 0.5), DIVER: (45.0, 30.0, 12.0), AUV: (-25.0, 40.0, 6.0)}
LOSS_CURVE = ((0.0, 0.02), (150.0, 0.05), (500.0, 0.4), (800.0, 1.0))
