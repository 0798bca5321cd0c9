//! The seam network as chains: maximal edge paths between *nodes*.
//!
//! A node is a vertex where the seam graph is not a plain curve: a singularity (always, even
//! with two seam edges), a vertex with one or three and more interior seam edges, or a seam
//! vertex on the mesh boundary. Chains run from node to node and never share an interior vertex
//! or an edge, which is what the geodesic straightener needs (it keeps nodes fixed). A closed
//! seam loop without any node is split into two chains at two opposite vertices (the first
//! by index and the one half-way along the loop), so it is straightened too but keeps its
//! place.
//!
//! Complexity: O(E).

use crate::patches::edge_between;
use clothcast_mesh::{EdgeData, Mesh, VertexData, VertexId};

/// Interior seam edges at every vertex.
pub fn seam_degree(mesh: &Mesh, seam: &EdgeData<bool>) -> VertexData<u32> {
    let mut deg = VertexData::filled(mesh.n_vertices(), 0u32);
    for e in mesh.edges() {
        if seam[e] && !mesh.is_boundary_edge(e) {
            for v in mesh.edge_vertices(e) {
                deg[v] += 1;
            }
        }
    }
    deg
}

/// The nodes of a seam network: see the module documentation.
pub fn nodes(mesh: &Mesh, seam: &EdgeData<bool>, fixed: &VertexData<bool>) -> VertexData<bool> {
    let deg = seam_degree(mesh, seam);
    mesh.vertices().map(|v| deg[v] > 0 && (fixed[v] || deg[v] != 2 || mesh.is_boundary_vertex(v))).collect()
}

/// Split the interior seam edges into chains between nodes (see the module documentation).
/// `fixed` vertices are nodes whatever their degree. Chains come out in a deterministic order
/// (by first node, then by first edge around it).
pub fn chains(mesh: &Mesh, seam: &EdgeData<bool>, fixed: &VertexData<bool>) -> Vec<Vec<VertexId>> {
    let is_node = nodes(mesh, seam, fixed);
    let mut used = EdgeData::filled(mesh.n_edges(), false);
    let mut out = Vec::new();
    let live = |e: clothcast_mesh::EdgeId| seam[e] && !mesh.is_boundary_edge(e);
    // Neighbours of v across live seam edges, in fan order.
    let seam_neighbours = |v: VertexId| -> Vec<(VertexId, clothcast_mesh::EdgeId)> {
        let mut out: Vec<(VertexId, clothcast_mesh::EdgeId)> = Vec::new();
        for w in mesh.vertex_neighbors(v) {
            if let Some(e) = edge_between(mesh, v, w)
                && live(e)
            {
                out.push((w, e));
            }
        }
        out
    };
    let walk = |start: VertexId,
                first: VertexId,
                e0: clothcast_mesh::EdgeId,
                used: &mut EdgeData<bool>,
                stop: &dyn Fn(VertexId) -> bool| {
        let mut path = vec![start, first];
        used[e0] = true;
        let mut cur = first;
        while !stop(cur) {
            let next = seam_neighbours(cur).into_iter().find(|&(_, e)| !used[e]);
            let Some((w, e)) = next else { break };
            used[e] = true;
            path.push(w);
            cur = w;
        }
        path
    };
    for v in mesh.vertices() {
        if !is_node[v] {
            continue;
        }
        for (w, e) in seam_neighbours(v) {
            if used[e] {
                continue;
            }
            out.push(walk(v, w, e, &mut used, &|u| is_node[u]));
        }
    }
    // Node-free loops.
    for e in mesh.edges() {
        if !live(e) || used[e] {
            continue;
        }
        let [a, b] = mesh.edge_vertices(e);
        let cycle = walk(a, b, e, &mut used, &|u| u == a);
        // cycle = [a, b, ..., a]; split at a and at the middle vertex.
        let mid = cycle.len() / 2;
        if mid == 0 || cycle.len() < 3 {
            continue;
        }
        out.push(cycle[..=mid].to_vec());
        out.push(cycle[mid..].to_vec());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patches::seam_edges;
    use clothcast_mesh::shapes;

    #[test]
    fn cross_splits_into_four_chains_and_loops_into_two() {
        let m = shapes::grid(10, 10, 1.0, 1.0);
        let id = |i: u32, j: u32| VertexId(j * 11 + i);
        let h: Vec<VertexId> = (2..=8).map(|i| id(i, 5)).collect();
        let v: Vec<VertexId> = (2..=8).map(|j| id(5, j)).collect();
        let seam = seam_edges(&m, &[h, v]);
        let none = VertexData::filled(m.n_vertices(), false);
        let c = chains(&m, &seam, &none);
        assert_eq!(c.len(), 4);
        assert!(c.iter().all(|p| p.len() == 4 && (p[0] == id(5, 5) || p[3] == id(5, 5))), "{c:?}");
        // A square loop without nodes: two chains sharing their end vertices.
        let mut lp: Vec<VertexId> = (2..6).map(|i| id(i, 2)).collect();
        lp.extend((2..6).map(|j| id(6, j)));
        lp.extend((3..=6).rev().map(|i| id(i, 6)));
        lp.extend((3..=6).rev().map(|j| id(2, j)));
        lp.push(id(2, 2));
        let seam = seam_edges(&m, &[lp]);
        let c = chains(&m, &seam, &none);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].len() + c[1].len(), 16 + 2);
        assert_eq!(c[0].last(), c[1].first());
        assert_eq!(c[0].first(), c[1].last());
    }
}
