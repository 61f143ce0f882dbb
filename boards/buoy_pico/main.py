# Runs at boot on the buoy's Pico: the node, for ever (acomm_mp.start).
from config import CONFIG

from acomm_mp.start import start

start(CONFIG)
