"""What a run hands over: the run folder (files written completely or not at all), the
rerun recording, figures, point clouds and programs."""
