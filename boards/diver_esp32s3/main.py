# Runs at boot on the diver's tablet: the node and its station, for ever.
# The status report carries what the tablet measures; with no sensor wired
# it is an empty DIVER_STATUS (one byte), which still says "alive".
# The config goes by module name, so start() can free it once checked.
from acomm.apps.station import diver_report
from acomm_mp.start import start

start("config", make_report=diver_report(lambda: {}))
