# The site of a physics channel and the scenario file that describes it: the
# water (depth, temperature, salinity, pH), the weather and traffic that make
# its noise (wind, shipping), how sound spreads, how its boundaries reflect,
# and optionally the nodes and their modems. JSON on both runtimes (json is
# in MicroPython); on CPython 3.11+ a .toml file is read with tomllib.
# Portable Python.

import json

from .fading import check_mode

# name -> default; docs/simulator.md says what each means
DEFAULTS = {
    "depth_m": 100.0,  # water depth (isovelocity channel for multipath)
    "temperature_c": 10.0,
    "salinity_psu": 35.0,
    "ph": 8.0,
    "wind_mps": 5.0,  # wind speed at the surface (noise)
    "shipping": 0.5,  # shipping activity 0 (none) .. 1 (heavy)
    "spreading_k": 1.5,  # 1 cylindrical, 2 spherical
    "absorption": "thorp",  # or "fg" (Francois-Garrison at this water)
    "sound_speed": 1500.0,
    "surface_loss_db": 1.0,  # lost per surface reflection
    "bottom_loss_db": 6.0,  # lost per bottom reflection
    "max_bounces": 6,  # image arrivals up to this many reflections
    "node_depth_m": 10.0,  # depth of a node given no position
    "fading": "rician",  # per arrival: "rician" (K from the echoes), "rayleigh" or "none" (acomm_sim.fading)
}

# Named sites (Site.preset): the conditions the channel bench states its
# figures in. "datasheet": open water deep enough that its echoes do not
# matter, a moderate wind, middling shipping (datasheets do not say theirs);
# "piovego": seed 004's river trial (Piovego canal, Padova): 1.5-2 m deep
# (1.75 taken), transducers at about 1 m, fresh water; its temperature,
# wind and shipping are assumed, and its bottom loss per reflection is the
# one free figure, fitted (before fading, with fading "none") so that the
# BPSK profile's PDR at 85 m is the mean of the seed's two trials (92.7 %;
# docs/simulator.md); it was not fitted again for fading.
PRESETS = {
    "datasheet": {"depth_m": 1000.0, "wind_mps": 5.0, "shipping": 0.5, "node_depth_m": 10.0},
    "piovego": {"depth_m": 1.75, "temperature_c": 15.0, "salinity_psu": 0.3, "ph": 7.5, "absorption": "fg",
                "wind_mps": 2.0, "shipping": 0.5, "node_depth_m": 1.0, "surface_loss_db": 0.5,
                "bottom_loss_db": 1.25, "max_bounces": 40},
}


class Site:
    """The water and weather of a physics channel: attributes named as in
    DEFAULTS; unknown keys raise ValueError (a typo must not pass silently)."""

    def __init__(self, **kw):
        for k in kw:
            if k not in DEFAULTS:
                raise ValueError("unknown site parameter %r; known: %s" % (k, ", ".join(sorted(DEFAULTS))))
        for k in DEFAULTS:
            v = kw.get(k, DEFAULTS[k])
            setattr(self, k, v if isinstance(DEFAULTS[k], str) else float(v))
        if self.absorption not in ("thorp", "fg"):
            raise ValueError("absorption is 'thorp' or 'fg', not %r" % (self.absorption,))
        check_mode(self.fading)
        if self.depth_m <= 0:
            raise ValueError("depth_m must be positive")
        self.max_bounces = int(self.max_bounces)

    @staticmethod
    def preset(name, **kw):
        """The named site of PRESETS, with some parameters changed."""
        d = dict(PRESETS[name])
        d.update(kw)
        return Site(**d)

    def as_dict(self):
        """The parameters as a dict (DEFAULTS' keys)."""
        return {k: getattr(self, k) for k in DEFAULTS}

    def with_(self, **kw):
        """A copy with some parameters changed."""
        d = self.as_dict()
        d.update(kw)
        return Site(**d)


class Scenario:
    """A scenario file's content: `site` (a Site), `channel` ("physics" or
    "curve"), `nodes` (a list of dicts: name, id, modem, position [east,
    north, depth], optional model: the physics modem model's name)."""

    def __init__(self, site, channel="physics", nodes=()):
        if channel not in ("physics", "curve"):
            raise ValueError("channel is 'physics' or 'curve', not %r" % (channel,))
        self.site = site
        self.channel = channel
        self.nodes = list(nodes)


def parse(data):
    """A Scenario from the decoded file (a dict with optional "site",
    "channel" and "nodes"); raises ValueError on bad content."""
    if not isinstance(data, dict):
        raise ValueError("a scenario file holds an object")
    for k in data:
        if k not in ("site", "channel", "nodes"):
            raise ValueError("unknown scenario key %r (site, channel, nodes)" % (k,))
    nodes = data.get("nodes", [])
    for n in nodes:
        if not isinstance(n, dict) or "name" not in n or "position" not in n:
            raise ValueError("a node has at least a name and a position: %r" % (n,))
    return Scenario(Site(**data.get("site", {})), data.get("channel", "physics"), nodes)


def read(path):
    """The decoded content of the scenario file at `path` (.json; .toml on
    CPython 3.11+), unchecked (parse checks it)."""
    if path.endswith(".toml"):
        import tomllib  # CPython 3.11+ only; the JSON form works everywhere

        with open(path, "rb") as f:
            return tomllib.load(f)
    with open(path) as f:
        return json.load(f)


def load(path):
    """The Scenario in the file at `path` (.json; .toml on CPython 3.11+)."""
    return parse(read(path))
