# The optional ray-traced transmission loss of the physics channel: Bellhop
# (Porter's Acoustics Toolbox) through arlpy's uwapm wrapper, over the
# site's depth and sound speed (a flat bottom: arlpy's 2-D environment), in
# place of spreading plus absorption. CPython only, and only where arlpy is
# installed (pip install 'acomm[bellhop]') and a `bellhop.exe` is on PATH
# (arlpy's name for it); otherwise available() says why not.
#
#   from acomm_cpython.bellhop import transmission_loss
#   ch = PhysicsChannel(site, tl=transmission_loss(site))
#
# Bellhop runs as a process per call, so answers are kept per (range to
# the metre step, depths to the metre, frequency): the channel asks again
# only when a pair has moved (PhysicsChannel's move_m).


def available():
    """(True, '') when arlpy and a Bellhop binary are there, else (False, why)."""
    try:
        import arlpy.uwapm as pm
    except ImportError:
        return False, "arlpy is not installed (pip install 'acomm[bellhop]')"
    try:
        models = pm.models()
    except Exception as e:  # arlpy looks for the binary itself; any failure means none
        return False, "arlpy could not list its models: %s" % e
    if "bellhop" not in models:
        return False, "no Bellhop binary (bellhop.exe) on PATH"
    return True, ""


def transmission_loss(site, step_m=10.0, bottom_soundspeed=1600.0, bottom_density=1600.0, bottom_absorption=0.5):
    """A tl(metres, zs, zr, f_khz) -> dB for PhysicsChannel(tl=...): Bellhop's
    incoherent transmission loss in an isovelocity channel of the site's
    depth and sound speed over a fluid bottom (speed m/s, density kg/m^3,
    absorption dB/wavelength: a sand-like default, to be set per site).
    Ranges are rounded to step_m. Raises RuntimeError where Bellhop is not
    available (see available())."""
    ok, why = available()
    if not ok:
        raise RuntimeError(why)
    import math

    import arlpy.uwapm as pm

    kept = {}

    def tl(metres, zs, zr, f_khz):
        r = max(step_m, round(metres / step_m) * step_m)
        depth = site.depth_m
        zs = min(max(round(zs), 0.5), depth - 0.5)
        zr = min(max(round(zr), 0.5), depth - 0.5)
        key = (r, zs, zr, f_khz)
        v = kept.get(key)
        if v is None:
            env = pm.create_env2d(depth=depth, soundspeed=site.sound_speed, bottom_soundspeed=bottom_soundspeed,
                                  bottom_density=bottom_density, bottom_absorption=bottom_absorption,
                                  tx_depth=zs, rx_depth=zr, rx_range=r, frequency=f_khz * 1000)
            loss = pm.compute_transmission_loss(env, mode=pm.incoherent)
            amp = abs(complex(loss.values.flat[0]))
            v = kept[key] = -20 * math.log10(amp) if amp > 0 else 300.0
        return v

    return tl
