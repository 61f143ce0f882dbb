# The buoy gateway: a Raspberry Pi Pico (RP2040) on a surface buoy, with a
# SeaTrac X150 beacon on UART0 and an Iridium 9603 (RockBLOCK) on UART1.
# It relays between the water and shore with store-and-forward: the divers'
# and the AUV's packets for "shore" reach it acoustically and leave over
# Iridium (the transport's link choice: the acoustic path to shore never
# answers, the satellite one does).
CONFIG = {
    "name": "buoy",
    "node_id": 1,
    "arch": "armv6m",  # mpy-cross -march for the RP2040 (Cortex-M0+)
    # the .mpy files `acomm flash` copies carry no line numbers: 4 KB more
    # heap for your own code on the stock firmware (buoy_pico.uf2 has them
    # frozen, with their lines, at no heap cost); True while debugging
    "mpy_lines": False,
    "peers": {"diver": 2, "shore": 3, "auv": 4},
    "routes": {},
    # learned routes (multi-hop over the acoustic links: route requests,
    # replies and errors): False, True, or a dict of
    # acomm.transport.routing.Routing's options, e.g. {"search_ms": 30000}.
    # About 3.5 KB more heap with it on; False loads none of it
    "routing": False,
    # 64 KiB of the Pico's flash filesystem for packets waiting to be sent
    "storage": {"path": "/data/acomm.store", "capacity": 65536, "max_record": 256},
    "max_packet": 4096,
    "watchdog_ms": 8000,  # the RP2040's watchdog tops out at 8.3 s
    "links": [
        # SeaTrac: 115200 8N1 by default; GP0 = UART0 TX, GP1 = UART0 RX
        {"name": "acoustic", "modem": "seatrac", "uart": 0, "baud": 115200, "tx": 0, "rx": 1,
         "medium": "acoustic", "link": {"advert_period_ms": 60000}},
        # Iridium 9603: 19200 8N1; GP4 = UART1 TX, GP5 = UART1 RX. No
        # adverts over satellite (each byte is paid for); a mailbox check
        # every 10 minutes when nothing else opened a session.
        {"name": "satellite", "modem": "iridium", "uart": 1, "baud": 19200, "tx": 4, "rx": 5,
         "medium": "satellite", "link": {"advert_period_ms": 3600000, "ack_timeout_ms": 60000},
         "options": {"mailbox_check_ms": 600000, "cost_tx": 0.02}},
    ],
    "station": None,  # a relay: it sends nothing of its own
    # The wall clock (lifespans, key epochs) is set from the Iridium modem's
    # AT-MSSTM. This board has no GPS wired; one on a spare UART would be
    #   "gps": {"uart": <id>, "baud": 9600, "tx": <pin or None>, "rx": <pin>},
    # (its NMEA RMC/ZDA sentences are read for the time only). The RP2040
    # has two UARTs, both taken by the modems above, so it stays off here.
}
