# The short fuzz on both runtimes (the CI runs `make test`, so
# this is the fuzz in CI): every target of acomm_sim.fuzz, a fixed seed and
# a fixed number of cases each, zero failures. `acomm fuzz --seconds N`
# runs the same targets for longer on CPython.
from acomm_sim import fuzz
from checks import TempDir

CASES = 150  # per target: ~3000 inputs in all, a few seconds


def test_short_fuzz_of_every_target_finds_nothing():
    # a folder of its own: two runs at once (CI and a developer) must not share the store's files
    with TempDir() as d:
        _fuzz_every_target(d.path)


def _fuzz_every_target(folder):
    targets = fuzz.all_targets(None, folder)
    names = [t.name for t in targets]
    for must in ("frame", "catalog.caddy", "imc", "store", "drv.seatrac", "drv.evologics", "drv.micromodem",
                 "drv.benthos", "drv.iridium", "drv.sms", "drv.transparent"):
        assert must in names, must
    results = fuzz.run(targets, seed=7, cases=CASES)
    for r in results:
        assert r.inputs == CASES, (r.name, r.inputs)
        assert r.failures == 0, (r.name, [(c, d.hex(), e) for c, d, e in r.first])


def test_cases_are_a_function_of_seed_target_and_number():
    # what makes `acomm fuzz --case N` reproduce a failure
    t = fuzz.all_targets(["frame"])[0]
    a = [fuzz.input_of(t, fuzz.case_rng(3, "frame", n)) for n in range(20)]
    b = [fuzz.input_of(t, fuzz.case_rng(3, "frame", n)) for n in (19, 5)]
    assert b == [a[19], a[5]] and len(set(a)) > 15


def test_the_oracle_catches_a_foreign_exception_and_a_driver_that_stops():
    # a decoder that lets a non-acomm error out, and one that breaks its
    # own oracle, are both reported with the input
    class Bad:
        name = "bad"
        corpus = [b"abc"]

        def run(self, data, rng):
            if len(data) > 2:
                raise KeyError("not an acomm error")

    r = fuzz.run([Bad()], seed=1, cases=40)[0]
    assert 0 < r.failures < 40 and "KeyError" in r.first[0][2]
    from acomm_sim import fuzz_drivers

    # the probe's check fails for a driver that hears nothing
    t = fuzz_drivers.DriverTarget(fuzz_drivers.SPECS[4])
    w, a, b = fuzz_drivers.two_nodes(t.spec)
    a.host_end.read = lambda n=-1: None  # the buoy's driver goes deaf
    assert not fuzz_drivers.exchange(w, a, b, "acoustic", b"x", 60000)
