"""ABB RAPID, in and out: the one place the project reads, models, writes and runs RAPID.

- `scenarios.rapid.syntax`: a module's syntax (its nodes, declarations, calls, routines) and
  `RapidError`;
- `scenarios.rapid.lexer`: a module's text checked to be text and cut into tokens;
- `scenarios.rapid.expression_parser` and `scenarios.rapid.parser`: the parser of a module's
  tokens into its syntax (expressions and arguments; declarations, routines, statements);
- `scenarios.rapid.module`: the module's model (`RapidModule`: its data, moves, tools and
  work objects), and `with_value`, which writes one datum's value into its text;
- `scenarios.rapid.reader`: the reader (`read_module`: names and values resolved);
- `scenarios.rapid.touches`: the approach/touch operations of one work object;
- `scenarios.rapid.oframe`: `with_oframe`, which writes a module back with one work object's
  object frame corrected;
- `scenarios.rapid.task`: a task read as a controller runs it, a set of modules (a folder, a
  backup's RAPID/TASKn, or several files) whose names resolve across them, LOCAL scope kept;
- `scenarios.rapid.instructions`: which RAPID instructions move the arm, and which are known;
- `scenarios.rapid.summary`: what was read, as text (`twincell rapid`);
- `scenarios.rapid.writer`: the corrected offline program written as a module (program.mod);
- `scenarios.rapid.flow`: the order in which a controller runs a task's statements;
- `scenarios.rapid.confdata`: a robtarget's configuration data, and the solution it asks for;
- `scenarios.rapid.planner`: a module or a task planned for the cell's controller the way an
  IRC5 without absolute accuracy runs it (the job's exported program and `twincell execute`),
  each move's data resolved by `scenarios.rapid.move_data` and its joints by
  `scenarios.rapid.nominal_motion`, into an `scenarios.rapid.execution_plan`;
- `scenarios.rapid.executor`: that plan run on the cell's controller.
"""
