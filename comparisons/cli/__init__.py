"""The command line: ``main`` parses and dispatches, one module per subcommand, ``common`` below them all.

    $ chatterbench compare feigin-pair --engines mujoco,pybullet --out out/fp
"""
