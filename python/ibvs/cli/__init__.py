"""ibvs.cli: the command line, `ibvs` / `python -m ibvs`; the entry point is ibvs.cli.main.main.

    main    the parser and the dispatch of each command
    args    argument types and checks (one line and exit status 2 for a bad argument), options
            shared by several commands
    run     `ibvs run`: one episode
    sweep   `ibvs sweep`: many episodes, a table and a figure
    replay  `ibvs replay`: a ROS 2 bag through a tracker and the servo

This package imports nothing itself, so that `ibvs.bench` can use ibvs.cli.args without the
whole command line.
"""
