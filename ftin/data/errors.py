"""The one error type every reader and preprocessing step raises for bad input."""


class DataFormatError(ValueError):
    """Input data violates the expected format.

    The message names the file, column or row and what was expected, so that the CLI can print it
    as one line and the REST API can return it as a 4xx body unchanged.
    """
