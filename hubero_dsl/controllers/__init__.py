"""Robot controllers: what drives a robot under test, built in or installed as plugins.

`base` defines what a controller sees (`Observation`) and returns (a velocity command), and
the `RobotController` protocol; `registry` finds controllers by name (entry-point group
`hubero.controllers`); `path`, `navigator` and `external` are the built-in ones.
"""
