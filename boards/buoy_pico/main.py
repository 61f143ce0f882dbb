# Runs at boot on the buoy's Pico: the node, for ever (acomm_mp.start).
# The config goes by module name, so start() can free it once checked.
from acomm_mp.start import start

start("config")
