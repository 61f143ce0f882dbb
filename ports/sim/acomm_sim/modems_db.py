# The modem models of the physics channel (acomm_sim.physchannel): what the
# link budget needs from each modem's datasheet, with where each figure
# comes from. A figure marked "assumed" is not in a source available to
# this project: it is a stated guess, to be replaced when a datasheet says
# otherwise (docs/simulator.md lists them). Portable Python.
#
# Fields of a model (a dict):
#   band_khz       (low, high) edges of the band it transmits and listens in
#   sl_db          source level, dB re 1 uPa at 1 m
#   bitrate        information bit rate of its data packets, bit/s
#   modulation     'psk' (coherent), 'dpsk' (differential), 'fsk' (non-coherent)
#   coding_gain_db how much less Eb/N0 its FEC needs than the bare modulation
#   preamble_s     duration of the detection preamble (matched filter)
#   pfa            false alarm probability its detector is set for
#   crc            True: a frame with a bit wrong is dropped (the modem checks
#                  it); False: the bytes go up as demodulated (the link's FEC)
#   tolerance_ms   delay spread it absorbs (guard, symbol, equaliser span):
#                  later echoes are interference (acomm_sim.multipath)
#   overhead_bytes modem framing added to each packet on the air
#   default_bytes  packet size when the emulator's packets are not bytes
#   range_m        range the datasheet states (None: none stated)
#   impl_loss_db   optional: how far the real receiver falls short of this
#                  ideal one (dB taken off every arrival's power); none of
#                  the models here sets it: no measured SNR threshold or
#                  receiver loss of these modems, independent of their
#                  stated ranges, was found (searched 2026-11-28; docs/
#                  simulator.md, "Measured"), and fitting it to those ranges
#                  would fit it to what it is compared with
#                  (channel_margin_to_datasheet_* in `acomm bench channel`
#                  says what would match the datasheet)
#   src            {field: source}

_SEATRAC = "Blueprint Subsea SeaTrac X150 datasheet and product page (blueprintsubsea.com/seatrac)"
# checked against public copies on 2026-11-27 (docs/simulator.md, "Modem models"):
_SEATRAC_TECH = ("'SeaTrac Technology', https://blueprintsubsea.com/seatrac/technology.php: "
                 "broadband spread spectrum signalling")
_SEATRAC_RATE = ("SeaTrac Serial Command Interface Reference UM-140-D00221-02, p. 116 (CID_DAT_SEND), "
                 "https://manualshive.com/en/manual/blueprint-subsea/seatrac-x100-series/"
                 "seatrac-x100-series_manual_2777810-116.html: 80 ms per data byte, i.e. 100 bit/s")
_NOT_FOUND = "not found in a public source on 2026-11-27"
_EVO = "EvoLogics S2C R 18/34 product sheet (evologics.de)"
_WHOI = ("WHOI Micromodem page, http://acomms.whoi.edu/micro-modem: 80-5400 bps, PSK band 5 kHz, FSK band 4 kHz; "
         "'Micromodems in the Field', https://acomms.whoi.edu/micro-modem/usage-scenarios: 25 kHz operation")
_WHOI_RATES = "/work/shared/ref/modem-protocols.md: Micro-Modem packet rates 0 (FH-FSK 80 bps), 1 (BCH 128:8, 250 bps), 5 (Hamming 14:9, 5300 bps)"
_BENTHOS = "Teledyne Benthos ATM-900 series brochure (LF band 9-14 kHz); rate code 2 = 140 bps MFSK in modem-protocols.md"
_BENTHOS_DAT = ("Teledyne Benthos DAT, an ATM-900 series extension, nauticexpo product page "
                "https://nauticexpo.com/ja/prod/teledyne-benthos/product-40202-539329.html: 140-15,360 bps, "
                "MFSK and PSK, rate-1/2 convolutional coding, LF/MF/Band C options (band edges not given)")
_SEED = "seed 004 section IV-B: SuM modem, 32 kHz carrier; BPSK 1.2 kHz band, rate 1/3 FEC, 400 bit/s; FHSS 10 kHz band, rate 1/2 FEC, 192 bit/s"
_ASSUMED = "assumed (no source available here)"



def _whoi_psk(bitrate, coding_gain_db, default_bytes, code):
    # a PSK rate of the Micro-Modem: the same band, level and detector, its own rate and code
    return {
        "band_khz": (22.5, 27.5), "sl_db": 185.0, "bitrate": bitrate, "modulation": "psk",
        "coding_gain_db": coding_gain_db, "preamble_s": 0.1, "pfa": 1e-4, "crc": True, "tolerance_ms": 10.0,
        "overhead_bytes": 0, "default_bytes": default_bytes, "range_m": None,
        "src": {"band_khz": _WHOI, "bitrate": _WHOI_RATES, "sl_db": _ASSUMED + "; " + _NOT_FOUND,
                "coding_gain_db": _ASSUMED + " (" + code + ")", "tolerance_ms": _ASSUMED + " (equaliser span)",
                "range_m": "no range stated in the sources here"},
    }


MODELS = {
    "seatrac_x150": {
        "band_khz": (24.0, 32.0), "sl_db": 176.0, "bitrate": 100.0, "modulation": "dpsk", "coding_gain_db": 0.0,
        "preamble_s": 0.1, "pfa": 1e-4, "crc": True, "tolerance_ms": 10.0, "overhead_bytes": 0,
        "default_bytes": 16, "range_m": 1000.0,
        "src": {"band_khz": _SEATRAC + " (24-32 kHz; not re-read here: " + _NOT_FOUND + ")",
                "sl_db": _SEATRAC + " (176 dB re 1 uPa @ 1 m; recalled, not re-read here: " + _NOT_FOUND + ")",
                "bitrate": _SEATRAC_RATE,
                "range_m": _SEATRAC + " (1 km; recalled, not re-read here: " + _NOT_FOUND + ")",
                "modulation": "spread spectrum per " + _SEATRAC_TECH + "; differential PSK " + _ASSUMED,
                "tolerance_ms": _ASSUMED, "preamble_s": _ASSUMED},
    },
    "evologics_s2cr_18_34": {
        "band_khz": (18.0, 34.0), "sl_db": 184.0, "bitrate": 976.0, "modulation": "psk", "coding_gain_db": 3.0,
        "preamble_s": 0.05, "pfa": 1e-4, "crc": True, "tolerance_ms": 20.0, "overhead_bytes": 0,
        "default_bytes": 32, "range_m": 3500.0,
        "src": {"band_khz": _EVO + " (the model's name: 18-34 kHz)",
                "range_m": _EVO + " (3500 m; recalled: " + _NOT_FOUND + ")",
                "bitrate": "instant messages at 976 bit/s (modem-protocols.md, oceansystemslab driver comment)",
                "sl_db": _ASSUMED + "; " + _NOT_FOUND, "coding_gain_db": _ASSUMED, "tolerance_ms": _ASSUMED,
                "preamble_s": _ASSUMED},
    },
    "whoi_mm_fsk": {
        "band_khz": (23.0, 27.0), "sl_db": 185.0, "bitrate": 80.0, "modulation": "fsk", "coding_gain_db": 3.0,
        "preamble_s": 0.1, "pfa": 1e-4, "crc": True, "tolerance_ms": 10.0, "overhead_bytes": 0,
        "default_bytes": 32, "range_m": None,
        "src": {"band_khz": _WHOI + " (band A centred on 25 kHz)", "bitrate": _WHOI_RATES,
                "sl_db": _ASSUMED + "; " + _NOT_FOUND, "coding_gain_db": _ASSUMED + " (rate 1/2 code)",
                "tolerance_ms": _ASSUMED,
                "range_m": "no range stated in the sources here"},
    },
    "whoi_mm_psk1": _whoi_psk(250.0, 6.0, 64, "BCH 128:8"),
    "whoi_mm_psk5": _whoi_psk(5300.0, 1.5, 256, "Hamming 14:9"),
    "benthos_atm900": {
        "band_khz": (9.0, 14.0), "sl_db": 185.0, "bitrate": 140.0, "modulation": "fsk", "coding_gain_db": 3.0,
        "preamble_s": 0.1, "pfa": 1e-4, "crc": True, "tolerance_ms": 25.0, "overhead_bytes": 0,
        "default_bytes": 32, "range_m": 6000.0,
        "src": {"band_khz": _BENTHOS + " (9-14 kHz edges not re-read here: " + _NOT_FOUND + "; LF band exists per "
                            + _BENTHOS_DAT + ")",
                "bitrate": _BENTHOS + "; lowest rate 140 bps per " + _BENTHOS_DAT,
                "range_m": "Teledyne Benthos brochure: 2-6 km, the far end (recalled, not re-read here: " + _NOT_FOUND + ")",
                "sl_db": _ASSUMED + "; " + _NOT_FOUND,
                "coding_gain_db": _ASSUMED + " (rate 1/2 code, repeated; the rate-1/2 coding per " + _BENTHOS_DAT + ")",
                "tolerance_ms": "the 25 ms guard of rate 2 (modem-protocols.md)"},
    },
    "bpsk": {
        "band_khz": (31.4, 32.6), "sl_db": 170.0, "bitrate": 400.0, "modulation": "psk", "coding_gain_db": 5.0,
        "preamble_s": 0.05, "pfa": 1e-4, "crc": False, "tolerance_ms": 0.83, "overhead_bytes": 12,
        "default_bytes": 14, "range_m": None,
        "src": {"band_khz": _SEED, "bitrate": _SEED, "overhead_bytes": "seed 004 section VI-A (12 B)",
                "coding_gain_db": "textbook gain of a K=7 convolutional code with soft Viterbi decoding, "
                                  "about 5 dB at BER 1e-5 (Proakis 8.2); the seed gives the rate, not the gain",
                "tolerance_ms": "one symbol: 1.2 kHz band, 1200 coded bit/s, no equaliser stated (assumed)",
                "sl_db": _ASSUMED, "range_m": "the seed states none; its trial is at 85 m"},
    },
    "fhss": {
        "band_khz": (27.0, 37.0), "sl_db": 170.0, "bitrate": 192.0, "modulation": "fsk", "coding_gain_db": 3.0,
        "preamble_s": 0.1, "pfa": 1e-4, "crc": False, "tolerance_ms": 2.6, "overhead_bytes": 10,
        "default_bytes": 14, "range_m": None,
        "src": {"band_khz": _SEED, "bitrate": _SEED, "overhead_bytes": "seed 004 section VI-A (10 B)",
                "coding_gain_db": _ASSUMED + " (rate 1/2 code, hard decisions)",
                "tolerance_ms": "one coded FSK symbol at 384 bit/s (assumed)",
                "sl_db": _ASSUMED, "range_m": "the seed states none; its trial is at 85 m"},
    },
}

# which model an emulator of the simulator is, by its class (and, for the
# packet modem, its bit rate), when the channel was not told
_BY_CLASS = {
    "SeatracEmulator": "seatrac_x150",
    "EvologicsEmulator": "evologics_s2cr_18_34",
    "MicroModemEmulator": "whoi_mm_fsk",
    "BenthosEmulator": "benthos_atm900",
}


def model(name):
    """The model dict of `name` (KeyError with the known names if unknown)."""
    try:
        return MODELS[name]
    except KeyError:
        raise KeyError("unknown modem model %r; known: %s" % (name, ", ".join(sorted(MODELS))))


def model_of_station(station, default="bpsk"):
    """The model name for an emulator attached to the channel: by its class,
    a packet modem by its bit rate (seed 004's two profiles), else default."""
    name = type(station).__name__
    if name == "PacketModemEmulator":
        return "fhss" if getattr(station, "bitrate", 400) == 192 else "bpsk"
    return _BY_CLASS.get(name, default)
