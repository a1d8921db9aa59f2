"""What a run tells its caller as it goes: a leaf module, so that the command line draws progress without loading the
stages.
"""

from __future__ import annotations


class Progress:
    """What a run tells its caller as it goes (the default tells nothing).

    ``parallel`` says whether the task went to the executor's workers (True)
    or runs in this process.
    """

    def started(self, task_id: str, why: str, parallel: bool) -> None:
        pass

    def finished(self, task_id: str, seconds: float, parallel: bool) -> None:
        pass

    def failed(self, task_id: str, error: BaseException, parallel: bool) -> None:
        pass
