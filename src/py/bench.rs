//! Developer entry points: the exit-face micro-benchmark and the Rust twin of the exact referee.

use super::arrays::{check_cols, rows, slice};
use super::errors::guarded;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The exit-face micro-benchmark: (method, precision, ns per decision, decisions that are not
/// among the exact exit faces of the line, decided by the referee) for every method and
/// precision, one thread.
#[pyfunction]
#[pyo3(signature = (n_tets=10_000, rays_per_tet=16, seed=1, repeat=5))]
pub(crate) fn exitface_bench(
    py: Python<'_>,
    n_tets: usize,
    rays_per_tet: usize,
    seed: u64,
    repeat: usize,
) -> PyResult<Vec<(&'static str, &'static str, f64, usize)>> {
    if n_tets == 0 || rays_per_tet == 0 {
        return Err(PyValueError::new_err(
            "n_tets and rays_per_tet must be positive",
        ));
    }
    py.detach(|| {
        guarded(|| {
            let cases = crate::bench::cases(n_tets, rays_per_tet, seed);
            let mut out = Vec::new();
            for &m in crate::traverse::METHODS {
                for p in ["f32", "f64"] {
                    let (ns, wrong) = crate::bench::exitface(m, p, &cases, repeat)?;
                    out.push((m, p, ns, wrong));
                }
            }
            Ok(out)
        })
    })
}

/// The exact referee (`crate::referee`, docs/referee.md) by brute force over every triangle,
/// for cross-checking `tetrace.referee` on small scenes: per ray `hit` (bool), `t` (the exact
/// first hit rounded to float64, inf on a miss), `triangle` (the smallest id of the tie set,
/// -1 on a miss) and `ties` (the size of the tie set). `tmin`/`tmax`: one per ray, or one.
#[pyfunction]
pub(crate) fn referee_first_hit<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: &Bound<'py, PyAny>,
    origins: PyReadonlyArray2<'py, f64>,
    directions: PyReadonlyArray2<'py, f64>,
    tmin: PyReadonlyArray1<'py, f64>,
    tmax: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyDict>> {
    use rayon::prelude::*;
    check_cols(&vertices, 3, "vertices")?;
    let v: Vec<[f64; 3]> = rows(slice(&vertices, "vertices")?);
    if v.iter().flatten().any(|x| !x.is_finite()) {
        return Err(PyValueError::new_err("vertices must be finite"));
    }
    let f: Vec<[i64; 3]> = if let Ok(a) = faces.extract::<PyReadonlyArray2<'py, i64>>() {
        check_cols(&a, 3, "faces")?;
        rows(slice(&a, "faces")?)
    } else if let Ok(a) = faces.extract::<PyReadonlyArray2<'py, i32>>() {
        check_cols(&a, 3, "faces")?;
        rows::<i32, 3>(slice(&a, "faces")?)
            .into_iter()
            .map(|r| r.map(i64::from))
            .collect()
    } else if let Ok(a) = faces.extract::<PyReadonlyArray2<'py, u32>>() {
        check_cols(&a, 3, "faces")?;
        rows::<u32, 3>(slice(&a, "faces")?)
            .into_iter()
            .map(|r| r.map(i64::from))
            .collect()
    } else {
        return Err(pyo3::exceptions::PyTypeError::new_err(
            "faces must be a 2-D int64, int32 or uint32 array",
        ));
    };
    if f.iter().flatten().any(|&i| i < 0 || i as usize >= v.len()) {
        return Err(PyValueError::new_err(
            "faces index vertices that do not exist",
        ));
    }
    let n = check_cols(&origins, 3, "origins")?;
    if check_cols(&directions, 3, "directions")? != n {
        return Err(PyValueError::new_err(
            "origins and directions must have the same number of rows",
        ));
    }
    let (o, d) = (
        slice(&origins, "origins")?,
        slice(&directions, "directions")?,
    );
    let (lo, hi) = (slice(&tmin, "tmin")?, slice(&tmax, "tmax")?);
    for (name, b) in [("tmin", lo), ("tmax", hi)] {
        if b.len() != n && b.len() != 1 {
            return Err(PyValueError::new_err(format!(
                "{name} must have {n} values (one per ray) or one"
            )));
        }
    }
    let tris: Vec<crate::referee::Tri> = f.iter().map(|t| t.map(|i| v[i as usize])).collect();
    // In tetrace's pool (`threads.rs`: fork-safe, the one rule for every parallel call), not
    // rayon's global one.
    let verdicts = py.detach(|| {
        guarded(|| {
            let at = |b: &[f64], i: usize| b[if b.len() == 1 { 0 } else { i }];
            crate::threads::install(None, || {
                (0..n)
                    .into_par_iter()
                    .map(|i| {
                        let p = |x: &[f64]| [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
                        crate::referee::first_hit(p(o), p(d), at(lo, i), at(hi, i), &tris)
                            .map(|v| (v.t, v.ties[0] as i64, v.ties.len() as i64))
                    })
                    .collect::<Vec<_>>()
            })
        })
    })?;
    let out = PyDict::new(py);
    let hit: Vec<bool> = verdicts.iter().map(Option::is_some).collect();
    let t: Vec<f64> = verdicts
        .iter()
        .map(|v| v.map_or(f64::INFINITY, |v| v.0))
        .collect();
    let tri: Vec<i64> = verdicts.iter().map(|v| v.map_or(-1, |v| v.1)).collect();
    let ties: Vec<i64> = verdicts.iter().map(|v| v.map_or(0, |v| v.2)).collect();
    out.set_item("hit", hit.into_pyarray(py))?;
    out.set_item("t", t.into_pyarray(py))?;
    out.set_item("triangle", tri.into_pyarray(py))?;
    out.set_item("ties", ties.into_pyarray(py))?;
    Ok(out)
}
