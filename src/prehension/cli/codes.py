"""Exit codes of the ``prehension`` command (documented in the README)."""

EXIT_OK = 0  # done; for solve: a verified solution was found
EXIT_BAD_INPUT = 2  # bad task, file or option: the message names it (argparse uses 2 too)
EXIT_INFEASIBLE = 3  # proven: no configuration satisfies the task
EXIT_GAVE_UP = 4  # limits reached with neither a solution nor a proof
EXIT_CHECK_FAILED = 5  # check: a stored solution does not satisfy its task
EXIT_APPROXIMATE = 6  # solve --approximate: only an answer within the looser (d_min) tolerances was found
EXIT_DROPPED = 7  # simulate: a grasp dropped the object (or was rejected); solve --hold: no candidate holds
