# The diver's tablet: an ESP32-S3 in a housing with a SeaTrac X010 beacon on
# UART1. It sends the diver's status every two minutes, alarms and chat
# lines, and receives positions and commands (acomm.apps.station). Packets for
# shore go through the buoy, which forwards them over Iridium.
CONFIG = {
    "name": "diver",
    "node_id": 2,
    "arch": "xtensawin",  # mpy-cross -march for the ESP32-S3
    "peers": {"buoy": 1, "shore": 3, "auv": 4},
    "routes": {"shore": "buoy"},
    "storage": {"path": "/data/acomm.store", "capacity": 32768, "max_record": 256},
    "max_packet": 2048,
    "watchdog_ms": 10000,
    "links": [
        # SeaTrac on UART1: GPIO17 TX, GPIO18 RX, 115200 8N1
        {"name": "acoustic", "modem": "seatrac", "uart": 1, "baud": 115200, "tx": 17, "rx": 18,
         "medium": "acoustic", "link": {"advert_period_ms": 60000}},
    ],
    "station": {"report_to": "buoy", "alarm_to": "buoy", "report_period_s": 120},
}
