//! Disjoint sets over `0..n` (union-find with path halving), used to group elements around a
//! node in the split (`crate::split`, and in 3D `crate::tetmesh::TetMesh::split_along`) and to
//! find the connected components of the flow network (`crate::flow::steady`).
//!
//! The representative of a set is always its smallest member: `union` hangs the larger root
//! under the smaller one. So the grouping and the representatives do not depend on the order of
//! the unions or on path compression.

/// Disjoint sets over `0..n`.
#[derive(Debug, Clone)]
pub struct UnionFind {
    parent: Vec<usize>,
}

impl UnionFind {
    /// `n` singleton sets.
    pub fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n).collect(),
        }
    }

    /// Representative (smallest member) of the set containing `x`.
    pub fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            let gp = self.parent[self.parent[x]];
            self.parent[x] = gp;
            x = gp;
        }
        x
    }

    /// Merge the sets of `a` and `b`; the merged set's representative is the smaller of the two
    /// representatives.
    pub fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent[ra.max(rb)] = ra.min(rb);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn representative_is_the_smallest_member() {
        let mut uf = UnionFind::new(7);
        uf.union(5, 3);
        uf.union(6, 5);
        uf.union(4, 1);
        uf.union(3, 4);
        let roots: Vec<usize> = (0..7).map(|i| uf.find(i)).collect();
        assert_eq!(roots, [0, 1, 2, 1, 1, 1, 1]);
        uf.union(2, 2);
        assert_eq!(uf.find(2), 2);
    }
}
