"""The names of the policies the servo evaluation runs.

The policies are made by [`servo.task.evaluation.make_policy`][servo.task.evaluation.make_policy];
the names are kept apart from the policies so that a command line can offer them without importing
them (``topomap --help`` would load scikit-learn and the controllers).
"""

POLICIES = ("servo", "signal", "oracle", "greedy", "greedy-target", "random")

TRUTH_POLICY = "oracle"
"""The one policy the runner gives the env's truth (``info``: the true pose), by name: the
upper bound. No other policy, and no outside one, is given it."""
