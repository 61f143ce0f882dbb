# The benchmarks (`acomm bench`, BENCHMARKS.md): the table of benchmarks and
# their runner (table), the MicroPython side (runtime, a leaf the workloads
# may import), the workloads themselves (workloads/: those that measure
# portable code also run as scripts under the MicroPython unix port and
# import only acomm and their own folder), the report's writer
# (benchmarks_md), the fuzzer's coverage (fuzzcov) and the buoy on an
# emulated Pico (picobuoy, for `acomm bench board`). Imports the library,
# board, demo, emulate, acomm_sim, acomm_web and acomm_mp.
