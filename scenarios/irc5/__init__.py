"""The job's end of an ABB IRC5: the controller API (cell.Controller) over the controller's
own interfaces, Robot Web Services 1.0 and EGM, with the line laser's profile stream
(scenarios.irc5.remote_controller). It drives a real controller, or `twincell serve` in
another process; it never sees a simulation: the truth, if there is one, is on the other
side of the socket.
"""
