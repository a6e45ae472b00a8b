"""The node of a recursive bisection tree, shared by both methods' trees.

The manifold clustering (Grudic & Mulligan, Section II-C, ``mapping.manifold.tree``) and the
observation grouping (Blanco et al., Section II-B, ``mapping.grouping.normalized_cut``) both bisect
their data recursively. Their nodes are [`SplitNode`][mapping.split_tree.SplitNode] s with one
convention: a node's ``children`` are its two halves, or the empty tuple for a leaf. Each method
subclasses it to record its own split criterion (Omega(2) with its sigma and alpha; the Ncut).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

__all__ = ["SplitNode"]


@dataclass(eq=False)
class SplitNode:
    """A node of a recursive bisection tree (nodes compare by identity).

    Attributes
    ----------
    indices : ndarray of int
        The samples (graph nodes) in this node.
    children : tuple of SplitNode
        The two halves if this node was split, else empty (a leaf).

    Parameters
    ----------
    indices : ndarray of int
        The samples of this node.
    children : tuple of SplitNode, default ()
        The two halves of a split node; empty for a leaf.

    Examples
    --------
    >>> import numpy as np
    >>> from mapping import SplitNode
    >>> root = SplitNode(np.arange(4), (SplitNode(np.array([0, 1])), SplitNode(np.array([2, 3]))))
    >>> root.is_leaf, [node.indices.tolist() for node in root.walk()]
    (False, [[0, 1, 2, 3], [0, 1], [2, 3]])

    See Also
    --------
    mapping.manifold.ManifoldClustering : Its ``tree_`` of recursive splits.
    mapping.grouping.recursive_ncut_partition : The grouping's tree of Ncut splits.
    """

    indices: np.ndarray
    children: tuple[SplitNode, ...] = ()

    @property
    def is_leaf(self) -> bool:
        """Whether this node was left whole."""
        return not self.children

    def walk(self) -> Iterator[SplitNode]:
        """Traverse the tree in pre-order (a node, then its first subtree, then its second).

        Yields
        ------
        SplitNode
            Each node of the subtree rooted here, this one first.
        """
        stack = [self]
        while stack:  # explicit stack: no recursion limit on deep trees of long trajectories
            node = stack.pop()
            yield node
            stack.extend(reversed(node.children))

    def leaves(self) -> list[SplitNode]:
        """Return the leaves left to right (the first half's before the second's).

        Returns
        -------
        list of SplitNode
            The nodes without children.
        """
        return [node for node in self.walk() if node.is_leaf]
