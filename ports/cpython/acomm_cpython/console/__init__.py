# The console of a node on the command line (`acomm node`, `acomm run`):
# eventlines (events as text or JSON lines), console (the typed commands)
# and nodeloop (the real-time loop: stdin, --web, start-up, SIGTERM).
# Imports the library (acomm_cpython's top-level modules) and acomm_web.
