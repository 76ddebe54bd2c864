"""Errors the harness reports to a user as one line, with exit code 2."""


class InputError(ValueError):
    """Bad input from the user: a scene, parameter, model file or option the harness cannot use.

    The command-line interface prints ``str(err)`` as a single line on stderr and exits with 2.
    The message names the problem and, where there is one, the file.
    """
