"""A synchronous two-level replay of the museum experiment, driving PlanSets only.

It does by hand what the agent runtime does with messages (ALGORITHMS.md §4–§5),
so the plan-maintenance layer can be tested without an event loop: the parent
plans areas, the child executes each parent action by planning nodes; an
emergency suspends both levels' running actions and stacks both goals.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from htnagent.domain import Domain, State
from htnagent.planner import plan
from htnagent.planset import PlanSet, Replanning
from htnagent.terms import Atom, parse


@dataclass
class Level:
    domain: Domain
    belief: State
    mode: Replanning
    stack: list[PlanSet] = field(default_factory=list)
    active: PlanSet | None = None
    resumed_during_emergency: bool = False

    def plansets(self) -> list[PlanSet]:
        return [p for p in [self.active, *self.stack] if p is not None]

    def succeeded(self, action: Atom) -> None:
        after = self.domain.apply(self.belief, action)
        assert after is not None, f"{action} not applicable"
        for ps in self.plansets():
            ps.action_succeeded(action, self.belief, after)
        self.belief = after

    def suspended(self, action: Atom) -> None:
        after = self.domain.suspend(self.belief, action)
        for ps in self.plansets():
            ps.action_suspended(action, self.belief, after)
        self.belief = after


@dataclass
class Outcome:
    parent_kept: float
    parent_scratch: float
    child_kept: float | None
    child_scratch: float | None
    robot_path: list[str]


def run_situation(
    areas: Domain,
    nodes: Domain,
    start: str,
    goal: str,
    interrupted: str,
    emergency: str,
    mode: Replanning = Replanning.ONLINE,
) -> Outcome:
    """Goal ``goto(goal)``; when the child starts ``interrupted``, emergency ``goto(emergency)``."""
    parent = Level(areas, areas.initial_state(start), mode)
    child = Level(nodes, nodes.initial_state(start), mode)
    path = [start]
    interrupted_action = parse(interrupted)
    outcome: dict[str, float | None] = {}

    def child_execute(task: Atom, watch: bool) -> bool:
        """Run a parent action at the child; False if it was suspended."""
        ps = PlanSet(nodes, task, mode)
        child.active = ps
        assert ps.ensure(child.belief), f"child cannot plan {task}"
        while not ps.finished:
            assert ps.ensure(child.belief)
            best = ps.best
            assert best is not None
            action = best.steps[0].action
            if watch and action == interrupted_action:
                child.suspended(action)
                child.stack.append(ps)
                child.active = None
                return False
            child.succeeded(action)
            if action.name == "move" or action.name in ("resume", "rollback"):
                path.append(_robot_node(child.belief))
        child.active = None
        return True

    def child_resume(task: Atom) -> None:
        ps = child.stack.pop()
        assert ps.goal == task
        if mode is Replanning.NAIVE:
            ps.drop()
        ps.ensure(child.belief)
        ps.shorten_detours(child.belief)
        best = ps.best
        assert best is not None
        outcome["child_kept"] = best.cost
        scratch = plan(nodes, child.belief, [task]).best
        assert scratch is not None
        outcome["child_scratch"] = scratch.cost
        child.active = ps
        while not ps.finished:
            assert ps.ensure(child.belief)
            best = ps.best
            assert best is not None
            child.succeeded(best.steps[0].action)
            path.append(_robot_node(child.belief))
        child.active = None

    def parent_run(goal_task: Atom, watch: bool) -> None:
        ps = parent.active
        assert ps is not None and ps.ensure(parent.belief)
        while not ps.finished:
            assert ps.ensure(parent.belief), f"parent cannot plan {goal_task}"
            best = ps.best
            assert best is not None
            action = best.steps[0].action
            if action.name == "resume":
                inner = action.args[0]
                assert isinstance(inner, Atom)
                child_resume(inner)
                if parent.stack:
                    parent.resumed_during_emergency = True
                parent.succeeded(action)
                continue
            done = child_execute(action, watch)
            if done:
                parent.succeeded(action)
                continue
            # Algorithm 3: suspend the running action and goal, run the emergency, resume.
            parent.suspended(action)
            parent.stack.append(ps)
            em = PlanSet(areas, parse(f"goto({emergency})"), mode)
            parent.active = em
            em.make(parent.belief)
            parent_run(em.goal, False)
            parent.active = parent.stack.pop()
            resumed = parent.active
            if mode is Replanning.NAIVE:
                resumed.drop()
            resumed.ensure(parent.belief)
            kept = resumed.best
            assert kept is not None
            outcome["parent_kept"] = kept.cost
            scratch = plan(areas, parent.belief, [goal_task]).best
            assert scratch is not None
            outcome["parent_scratch"] = scratch.cost
            pending = Atom("resume", (action,))
            resumed_meanwhile = parent.resumed_during_emergency
            if not resumed_meanwhile and kept.steps[0].action != pending:
                # Algorithm 2: the suspended action will not be resumed: clear it below.
                if child.stack:
                    child.stack.pop()
                before = parent.belief
                parent.belief = areas.clear(before, action)
                resumed.belief_changed(before, parent.belief)
                resumed.ensure(parent.belief)
            resumed.shorten_detours(parent.belief)
            kept = resumed.best
            assert kept is not None
            outcome["parent_kept"] = kept.cost
            watch = False
            ps = resumed

    top = PlanSet(areas, parse(f"goto({goal})"), mode)
    parent.active = top
    top.make(parent.belief)
    parent_run(top.goal, True)
    return Outcome(
        outcome["parent_kept"] or 0.0,
        outcome["parent_scratch"] or 0.0,
        outcome.get("child_kept"),
        outcome.get("child_scratch"),
        path,
    )


def _robot_node(belief: State) -> str:
    for f in belief.dynamic:
        if f.name == "at":
            return str(f.args[0])
    raise AssertionError(f"robot not at a node: {belief}")
