# Runs at boot on the diver's tablet: the node and its station, for ever.
# The status report carries what the tablet measures; with no sensor wired
# it is an empty DIVER_STATUS (one byte), which still says "alive".
from config import CONFIG

from acomm.station import diver_report
from acomm_mp.start import start

start(CONFIG, make_report=diver_report(lambda: {}))
