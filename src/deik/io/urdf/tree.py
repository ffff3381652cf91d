"""The link tree of a URDF robot: the root, who is whose parent, and the sub-tree or chain a
user picks by base and tip link names."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NoReturn

from deik.errors import FileFormatError, UnknownNameError
from deik.io.urdf.elements import UrdfJoint, UrdfLink
from deik.suggest import did_you_mean


class LinkTree:
    """Links and joints of a parsed robot by name, checked to form one tree."""

    def __init__(self, links: list[UrdfLink], joints: list[UrdfJoint], source: str):
        self.source = source
        self._lines = {}
        self.links = {}
        for link in links:
            self._lines["link", link.name] = link.line
            if link.name in self.links:
                self.failure(link.name, "link")("duplicate link name; every link needs its own name")
            self.links[link.name] = link
        if not self.links:
            raise FileFormatError(source, "the robot has no <link>")
        self.joints, self.joint_of, self.children = {}, {}, {name: [] for name in self.links}
        for joint in joints:
            self._lines["joint", joint.name] = joint.line
            fail = self.failure(joint.name)
            if joint.name in self.joints:
                fail("duplicate joint name; every joint needs its own name")
            for end in (joint.parent, joint.child):
                if end not in self.links:
                    fail(f"names unknown link {end!r}{did_you_mean(end, self.links)}")
            if joint.child in self.joint_of:
                fail(
                    f"link {joint.child!r} already has parent joint {self.joint_of[joint.child].name!r}; "
                    "a URDF is a tree"
                )
            self.joints[joint.name] = joint
            self.joint_of[joint.child] = joint
            self.children[joint.parent].append(joint.child)
        roots = [name for name in self.links if name not in self.joint_of]
        if not roots:  # every link has a parent: the joints close a loop
            loop = self._loop()
            raise FileFormatError(
                source,
                f"the joints form a cycle ({' -> '.join(loop)}); a URDF is a tree: remove the joint that closes it",
            )
        if len(roots) != 1:
            raise FileFormatError(source, f"the links must form one tree with one root, found roots {roots}")
        self.root = roots[0]
        if len(self.below(self.root)) != len(self.links):
            cut = sorted(set(self.links) - set(self.below(self.root)))
            raise FileFormatError(source, f"links {cut[:5]} are not connected to the root {self.root!r} (a cycle?)")

    def _loop(self) -> list[str]:
        """The links of one cycle of parent joints, first link repeated at the end (every link
        has a parent, so following parents from any link comes back round)."""
        seen, link = [], next(iter(self.links))
        while link not in seen:
            seen.append(link)
            link = self.joint_of[link].parent
        loop = seen[seen.index(link) :]
        return [*reversed(loop), loop[-1]]

    def failure(self, name: str, tag: str = "joint") -> Callable[[str], NoReturn]:
        """A function that raises FileFormatError about element `name` at its line."""

        def fail(problem: str):
            raise FileFormatError(self.source, problem, line=self._lines.get((tag, name)), element=f"{tag} {name!r}")

        return fail

    def joint_child(self, joint_name: str) -> str:
        return self.joints[joint_name].child

    def below(self, link: str) -> list[str]:
        """`link` and every link under it, parents before children."""
        order, stack = [], [link]
        while stack:
            name = stack.pop()
            order.append(name)
            stack.extend(reversed(self.children[name]))
        return order

    def _link(self, name: str, role: str) -> str:
        if name not in self.links:
            raise UnknownNameError(f"{role} link {name!r} is not in {self.source}{did_you_mean(name, self.links)}")
        return name

    def select(self, base: str | None, tip: str | Sequence[str] | None) -> list[str]:
        """Links of the sub-tree under `base`, or of the paths from `base` to each `tip`,
        parents before children (the base first)."""
        base = self.root if base is None else self._link(base, "base")
        subtree = self.below(base)
        if tip is None:
            return subtree
        keep = {base}
        for name in [tip] if isinstance(tip, str) else list(tip):
            link = self._link(name, "tip")
            if link not in subtree:
                raise UnknownNameError(
                    f"tip link {name!r} is not below base link {base!r}; pick a base on its path from {self.root!r}"
                )
            while link != base:
                keep.add(link)
                link = self.joint_of[link].parent
        return [name for name in subtree if name in keep]
