"""The application: command line, the whole run of a case, compare/post/fatigue commands,
figures, logging and resource checks."""
