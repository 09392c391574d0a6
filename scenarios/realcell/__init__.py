"""The simulated real cell of a job: its set-up (the object at its true pose, the cell's
errors), the evaluator (the only reader of the truth) and the recording of the truth."""
