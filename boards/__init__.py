# The boards shipped with acomm, one folder per board (config.py, main.py).
# This file makes the folder the package `acomm_boards`, so that an installed
# wheel carries the boards as package data and `acomm flash`, `acomm run`
# and the footprint bench find them (acomm_cpython.board.boardfiles.boards_dir).
# Nothing here runs on a board.
