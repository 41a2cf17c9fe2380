"""The commands' workflows as library functions: options in, a typed result out.

Each workflow chains the floors below it (scene -> plan -> robot -> export -> sim -> view) the
way its command does, takes an options dataclass whose fields are checked and named in its
errors, and returns a result with ``summary()`` (what the command prints) and ``write(dir)``
(what it writes, atomically). ``cli.py`` only parses, calls, prints and maps the options'
field names to the flags a person typed.
"""
