# The simulated ocean's demonstrations and studies: the demo mission (mission,
# apps, traffic, report, web for `acomm demo`), the places it happens in
# (places: its nodes, their addresses and positions, the channel's loss
# curve), and sweeps over its parameters (sweep, sweep_scenarios,
# sweep_plot for `acomm sweep`). Imports the library, acomm_sim and
# acomm_web; the command lines are acomm_cpython.cli.demo and .sweep.
