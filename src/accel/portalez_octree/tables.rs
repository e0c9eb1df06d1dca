//! The two lookup tables of Portalez & Duguet's walk (specs §(a)), generated from the geometry
//! they encode rather than typed in, so the walk and the tests share one derivation; the tests
//! compare them with the published arrays.
//!
//! Conventions (reading A): corner v = x + 2y + 4z with bit 1 on the max side; faces
//! 0 = +y, 1 = +x, 2 = −y, 3 = −x, 4 = +z, 5 = −z; a sign pattern is bx + 2by + 4bz with
//! b = 1 ⇔ Π < 0, Π_k(P) = ((P − o) × d)_k.

/// The axis of each face.
pub const FACE_AXIS: [usize; 6] = [1, 0, 1, 0, 2, 2];
/// Whether each face lies on its axis's max side.
pub const FACE_POSITIVE: [bool; 6] = [true, true, false, false, true, false];

/// The face of `axis` on its max side (`positive`) or min side.
pub const fn face_of(axis: usize, positive: bool) -> usize {
    match (axis, positive) {
        (0, true) => 1,
        (0, false) => 3,
        (1, true) => 0,
        (1, false) => 2,
        (2, true) => 4,
        _ => 5,
    }
}

/// The two axes in a face of `axis`, in x, y, z order (u < w).
pub const fn in_plane(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// `outFacesLookup[row][bits]`: the exit face of a box for a direction in octant `row`
/// ([dx>0] + 2[dy>0] + 4[dz>0], which is also the exit corner), from the signs of Π on the
/// three axis lines through the exit corner; 7 where the signs are cyclic (impossible).
///
/// Why: at the exit corner C, C − o = (t_x d_x, t_y d_y, t_z d_z) on the axes' exit planes,
/// so Π_x = d_y d_z (t_y − t_z), Π_y = d_z d_x (t_z − t_x), Π_z = d_x d_y (t_x − t_y): each
/// sign compares two exit distances, and the exit face is the axis whose distance is least.
pub fn out_faces_lookup() -> [[u8; 8]; 8] {
    let mut table = [[7u8; 8]; 8];
    for (row, entries) in table.iter_mut().enumerate() {
        let pos = [0, 1, 2].map(|k| row >> k & 1 == 1);
        let s = pos.map(|p| if p { 1i32 } else { -1 });
        for (bits, entry) in entries.iter_mut().enumerate() {
            let neg = [0, 1, 2].map(|k| bits >> k & 1 == 1);
            // less[k]: t_{k+1} < t_{k+2} (Π_k < 0 ⇔ that, when d_{k+1} d_{k+2} > 0).
            let less = [0, 1, 2].map(|k| neg[k] == (s[(k + 1) % 3] * s[(k + 2) % 3] > 0));
            let lt = |i: usize, j: usize| {
                // t_i < t_j for i ≠ j, from the Π of the third axis.
                let k = 3 - i - j;
                if i == (k + 1) % 3 {
                    less[k]
                } else {
                    !less[k]
                }
            };
            for (i, &p) in pos.iter().enumerate() {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                if lt(i, j) && lt(i, k) {
                    *entry = face_of(i, p) as u8;
                }
            }
        }
    }
    table
}

/// The sign of δ_m = c_m − X_m (c: the centre of a face of `axis` crossed with d_axis of
/// sign `sn`; X: where the ray crosses that face's plane) read from the sign `pi` of Π_k at
/// c, k the face's other in-plane axis. Why: c − o = (c − X) + t_X d, so Π(c) = (c − X) × d,
/// and with (c − X)_axis = 0 the in-plane components reduce to one product with d_axis.
pub fn delta_sign(axis: usize, m: usize, pi: i32, sn: i32) -> i32 {
    let k = 3 - axis - m;
    // Π_k = δ_{k+1} d_{k+2} − δ_{k+2} d_{k+1}: the term with d_axis survives.
    let c = if axis == (k + 2) % 3 { 1 } else { -1 };
    pi * sn * c
}

/// `faceToNeighborIndex[face][bits]`: which of a face's four finer neighbours the ray enters,
/// from the signs of Π on the axis lines through the face's centre: neighbour
/// j = [X_u < c_u] + 2 [X_w < c_w] (u < w the in-plane axes), so (hi, hi) is 0. The bit of
/// the face's own axis does not matter.
pub fn face_to_neighbor_index() -> [[u8; 8]; 6] {
    let mut table = [[0u8; 8]; 6];
    for (face, entries) in table.iter_mut().enumerate() {
        let axis = FACE_AXIS[face];
        let (u, w) = in_plane(axis);
        let sn = if FACE_POSITIVE[face] { 1 } else { -1 };
        for (bits, entry) in entries.iter_mut().enumerate() {
            let pi = |k: usize| if bits >> k & 1 == 1 { -1 } else { 1 };
            // δ_u comes from Π_w, δ_w from Π_u.
            let du = delta_sign(axis, u, pi(w), sn);
            let dw = delta_sign(axis, w, pi(u), sn);
            *entry = ((du > 0) as u8) + 2 * ((dw > 0) as u8);
        }
    }
    table
}
