//! Kuhn grids: the valid tet meshes the tests and the fuzzer build their scenes from (a cube
//! grid, each cube cut into 6 tets that conform across cubes), and the faces of a tet list.

/// An n³ grid of cubes over \[0,1\]³, each cut into 6 Kuhn tets, interior points jittered by
/// `jitter` (0: every face plane is shared by many faces, `uniform` draws in [0, 1)) and
/// rounded to multiples of 2^-24. The crate's tests build their grids with it too.
pub fn kuhn_grid(
    n: usize,
    jitter: f64,
    mut uniform: impl FnMut() -> f64,
) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
    let m = n + 1;
    let id = |x: usize, y: usize, z: usize| (x + m * (y + m * z)) as u32;
    let mut pts = Vec::new();
    for z in 0..m {
        for y in 0..m {
            for x in 0..m {
                let mut p = [x, y, z].map(|c| c as f64 / n as f64);
                for (a, c) in [x, y, z].into_iter().enumerate() {
                    if c > 0 && c < n {
                        p[a] += (uniform() - 0.5) * jitter / n as f64;
                    }
                }
                pts.push(p.map(|x| (x * 16_777_216.0).round() / 16_777_216.0));
            }
        }
    }
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut tets = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                for p in perms {
                    let mut c = [x, y, z];
                    let mut t = [id(x, y, z), 0, 0, 0];
                    for (k, &a) in p.iter().enumerate() {
                        c[a] += 1;
                        t[k + 1] = id(c[0], c[1], c[2]);
                    }
                    tets.push(t);
                }
            }
        }
    }
    (pts, tets)
}

/// Every face of every tet, each sorted, the list sorted (interior faces appear twice).
pub fn tet_faces(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut f: Vec<[u32; 3]> = tets
        .iter()
        .flat_map(|t| {
            [
                [t[1], t[2], t[3]],
                [t[0], t[2], t[3]],
                [t[0], t[1], t[3]],
                [t[0], t[1], t[2]],
            ]
            .map(|mut k| {
                k.sort();
                k
            })
        })
        .collect();
    f.sort();
    f
}
