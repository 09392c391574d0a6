"""The twin as a controller: the simulated real cell behind the interfaces an ABB IRC5 with
RobotWare 6 offers its clients, Robot Web Services 1.0 (HTTP, scenarios.twin.rws) and
Externally Guided Motion (UDP, scenarios.twin.egm), so that the client code users have for a
real cell drives the twin. The controller's state (scenarios.twin.twin_controller) runs programs
on the one executor `twincell execute` uses (scenarios.rapid.planner and
scenarios.rapid.executor) and knows only what a controller knows: this package never sees the
truth (`twincell serve`, in scenarios.jobs.serve, builds the cell and measures what was run).
"""
