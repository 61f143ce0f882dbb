# The applications (acomm/apps): stubs only for what a topside program calls.
