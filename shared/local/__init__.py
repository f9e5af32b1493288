"""Local launchers: Redis, the services and nginx as child processes (demo, benches, tests).

The top layer of `shared`: it may use any other layer, and nothing in `shared` imports it.
"""
