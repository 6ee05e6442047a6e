"""ibvs.study: studies of the control laws in the simulator.

    schemes     the control laws by name (SCHEMES, make, register_scheme)
    scenario    the set-up a sweep runs (Scenario, built-in worlds, TOML scenario files)
    sweep       convergence-basin studies at scale: one CSV row per episode, aggregate tables
    reproduce   the paper's experiments: every case, figures and the summary of `ibvs reproduce`
    joint_limits  joint-limit avoidance (ibvs.SecondaryTask) over random arm starts: outcome shares
    wide        a 220-degree fisheye on perspective against spherical features (`ibvs wide`, docs/wide-study.md)

Import the module you need (`from ibvs.study import sweep`); this package itself imports nothing.
"""
