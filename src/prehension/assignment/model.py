"""Open tasks and assignments (:mod:`prehension.tasks.open_task`), under the assignment package's name."""

from ..tasks.open_task import Assignment, OpenContact, OpenTask, concrete_task, enumerate_assignments

__all__ = ["OpenContact", "OpenTask", "Assignment", "enumerate_assignments", "concrete_task"]
