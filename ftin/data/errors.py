"""The one error type every reader and preprocessing step raises for bad input."""


class DataFormatError(ValueError):
    """Input data violates the expected format.

    The message names the file, column or row and what was expected, so that the CLI can print it
    as one line and the REST API can return it as a 4xx body unchanged.
    """


class TooManySamplesError(DataFormatError):
    """A recording holds more samples than the caller reads (``max_samples``).

    Apart from other format errors so that a server can answer it as "too large" (HTTP 413).
    ``samples`` may be an upper bound: a CSV's line count, taken before parsing.
    """

    def __init__(self, source: str, samples: int, limit: int) -> None:
        super().__init__(f"{source} has {samples} samples; at most {limit} are read")
        self.source = source
        self.samples = samples
        self.limit = limit
