//! Fracture networks as geometry: fractures (line segments with an aperture), their
//! intersections, and their discretisation into flow cells joined at nodes.
//!
//! Lengths in m, apertures in m. A random network is generated with ChaCha8 from a seed and
//! written into the output folder, so every run can be reproduced and inspected.

use crate::error::SetupError;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Most fractures in a network (given plus generated): the intersection search compares every
/// pair (1e5 fractures: 5e9 pairs, tens of seconds).
pub const MAX_FRACTURES: usize = 100_000;

/// Snapping distance as a fraction of the cell length.
pub const SNAP: f64 = 0.3;

/// One fracture: a straight segment with a uniform hydraulic aperture.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Fracture {
    /// Start point, m.
    pub from: [f64; 2],
    /// End point, m.
    pub to: [f64; 2],
    /// Hydraulic aperture, m.
    pub aperture: f64,
}

/// A seeded random network in a rectangle: `count` fractures with centres uniform in the box,
/// orientations `angles_deg[k] +- jitter_deg` (a family chosen uniformly per fracture), lengths
/// uniform in `length`, apertures log-uniform in `aperture`. Fractures are clipped to the box.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RandomNetwork {
    pub seed: u64,
    pub count: usize,
    /// Lower-left corner, m.
    #[serde(default)]
    pub origin: [f64; 2],
    /// Box size, m.
    pub size: [f64; 2],
    /// Mean orientations of the fracture families, degrees from the x axis.
    pub angles_deg: Vec<f64>,
    #[serde(default)]
    pub jitter_deg: f64,
    /// Length range, m.
    pub length: [f64; 2],
    /// Aperture range, m (sampled log-uniformly).
    pub aperture: [f64; 2],
}

/// A rigid fracture network for flow-only scenes.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NetworkSpec {
    /// Fractures given explicitly.
    #[serde(default)]
    pub fractures: Vec<Fracture>,
    /// Fractures generated at random (added to `fractures`).
    #[serde(default)]
    pub random: Option<RandomNetwork>,
    /// Target cell length, m: each piece of fracture between intersections is cut into
    /// ceil(piece / cell_length) equal cells. Intersections and ends closer than
    /// 0.3 cell_length to an existing network point snap to it, so no cell is shorter than
    /// that (the explicit flow step shrinks with the square of the shortest cell).
    pub cell_length: f64,
}

/// A discretised network: nodes (cell ends and junctions) and cells between two nodes.
#[derive(Clone, Debug, Default)]
pub struct CellNetwork {
    pub nodes: Vec<[f64; 2]>,
    /// (node a, node b, aperture m, index of the fracture it came from).
    pub cells: Vec<(u32, u32, f64, u32)>,
    /// The fractures the cells were cut from (explicit then generated).
    pub fractures: Vec<Fracture>,
}

impl RandomNetwork {
    /// The placement fields (families, box, lengths; not the apertures) are usable; errors
    /// name `prefix.<field>`.
    pub fn validate_geometry(&self, prefix: &str) -> Result<(), SetupError> {
        let bad = |f: &str, why: String| Err(SetupError::invalid(&format!("{prefix}.{f}"), why));
        let finite = |field: &str, v: &[f64]| -> Result<(), SetupError> {
            match v.iter().find(|x| !x.is_finite()) {
                Some(x) => bad(field, format!("{x} is not a finite number")),
                None => Ok(()),
            }
        };
        if self.angles_deg.is_empty() {
            return bad("angles_deg", "needs at least one family".into());
        }
        finite("angles_deg", &self.angles_deg)?;
        finite("origin", &self.origin)?;
        finite("size", &self.size)?;
        finite("length", &self.length)?;
        finite("jitter_deg", &[self.jitter_deg])?;
        if !(self.size[0] > 0.0 && self.size[1] > 0.0) {
            return bad("size", "must be positive".into());
        }
        if !(self.length[0] > 0.0 && self.length[1] >= self.length[0]) {
            return bad("length", "needs 0 < min <= max".into());
        }
        if !(0.0..=90.0).contains(&self.jitter_deg) {
            return bad(
                "jitter_deg",
                format!("must be in [0, 90] degrees, got {}", self.jitter_deg),
            );
        }
        // The origin plus the size must stay finite too (1e308 + 1e308 is not).
        let far = [self.origin[0] + self.size[0], self.origin[1] + self.size[1]];
        finite("size", &far)
    }

    pub fn generate(&self) -> Vec<Fracture> {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let [x0, y0] = self.origin;
        let [w, h] = self.size;
        let mut out = Vec::with_capacity(self.count);
        let mut tries = 0;
        while out.len() < self.count && tries < 100 * self.count.max(1) {
            tries += 1;
            let c = [x0 + rng.random_range(0.0..w), y0 + rng.random_range(0.0..h)];
            let fam = rng.random_range(0..self.angles_deg.len());
            let jitter = if self.jitter_deg > 0.0 {
                rng.random_range(-self.jitter_deg..=self.jitter_deg)
            } else {
                0.0
            };
            let ang = (self.angles_deg[fam] + jitter).to_radians();
            let len = rng.random_range(self.length[0]..=self.length[1]);
            let (la, lb) = (self.aperture[0].ln(), self.aperture[1].ln());
            let aperture = if lb > la {
                rng.random_range(la..=lb).exp()
            } else {
                self.aperture[0]
            };
            let d = [0.5 * len * ang.cos(), 0.5 * len * ang.sin()];
            let (mut a, mut b) = ([c[0] - d[0], c[1] - d[1]], [c[0] + d[0], c[1] + d[1]]);
            // Clip to the box (Liang-Barsky).
            if !clip(&mut a, &mut b, [x0, y0, x0 + w, y0 + h]) {
                continue;
            }
            if ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt() < 1e-6 * len.max(1e-300) {
                continue;
            }
            out.push(Fracture {
                from: a,
                to: b,
                aperture,
            });
        }
        out
    }
}

/// A square lattice of n horizontal and n vertical fractures 1 m apart on [0, n-1]^2 m, line k
/// in each direction with aperture `aperture(k)` (m): about 2 n^2 cells of 1 m, four at every
/// interior node (benchmarks and determinism tests).
pub fn lattice(n: usize, aperture: impl Fn(usize) -> f64) -> Vec<Fracture> {
    let len = (n - 1) as f64;
    let mut fr = Vec::with_capacity(2 * n);
    for k in 0..n {
        let (x, a) = (k as f64, aperture(k));
        fr.push(Fracture {
            from: [0.0, x],
            to: [len, x],
            aperture: a,
        });
        fr.push(Fracture {
            from: [x, 0.0],
            to: [x, len],
            aperture: a,
        });
    }
    fr
}

/// Clip segment a-b to a box [xmin, ymin, xmax, ymax]; false when nothing is left.
pub fn clip(a: &mut [f64; 2], b: &mut [f64; 2], bx: [f64; 4]) -> bool {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d[0], a[0] - bx[0]),
        (d[0], bx[2] - a[0]),
        (-d[1], a[1] - bx[1]),
        (d[1], bx[3] - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return false;
    }
    let a0 = *a;
    *a = [a0[0] + t0 * d[0], a0[1] + t0 * d[1]];
    *b = [a0[0] + t1 * d[0], a0[1] + t1 * d[1]];
    true
}

/// Parameters (along each segment, in [0, 1]) where segments p and q intersect, if they do
/// (including touching at an end, within `tol` in length units). Parallel overlaps are ignored.
fn intersect(p: &Fracture, q: &Fracture, tol: f64) -> Option<(f64, f64)> {
    let r = [p.to[0] - p.from[0], p.to[1] - p.from[1]];
    let s = [q.to[0] - q.from[0], q.to[1] - q.from[1]];
    let den = r[0] * s[1] - r[1] * s[0];
    let (lr, ls) = (
        (r[0] * r[0] + r[1] * r[1]).sqrt(),
        (s[0] * s[0] + s[1] * s[1]).sqrt(),
    );
    if den.abs() <= 1e-12 * lr * ls {
        return None;
    }
    let w = [q.from[0] - p.from[0], q.from[1] - p.from[1]];
    let t = (w[0] * s[1] - w[1] * s[0]) / den;
    let u = (w[0] * r[1] - w[1] * r[0]) / den;
    let (tt, tu) = (tol / lr, tol / ls);
    if t < -tt || t > 1.0 + tt || u < -tu || u > 1.0 + tu {
        return None;
    }
    Some((t.clamp(0.0, 1.0), u.clamp(0.0, 1.0)))
}

/// Statistics of a fracture network (`summary.json` `network`): what a sweep plots its results
/// against. Lengths in m, areas in m^2.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct NetworkStatistics {
    /// Fractures.
    pub count: usize,
    /// Their total length, m.
    pub total_length: f64,
    /// P21: total length per unit area of the region, 1/m.
    pub p21: f64,
    /// Pairs of fractures that cross or touch (within 1e-9 of the longer one's length).
    pub intersections: usize,
    /// Intersections per fracture, 2 x intersections / count: each crossing counts for both.
    pub intersections_per_fracture: f64,
    /// Fractures that cross no other.
    pub isolated: usize,
    /// The 2D percolation parameter sum(l_i^2) / area (dimensionless): for isotropic
    /// segments of one length, about 5.6 at the percolation threshold (the literature's
    /// continuum percolation value of N l^2 / A for sticks).
    pub percolation_parameter: f64,
}

/// [`NetworkStatistics`] of the segments `(from, to)` (m) in a region of `area` m^2.
/// Every pair is compared (O(n^2); at most 1e4 fractures in the rock: 5e7 pairs).
pub fn statistics(segments: &[([f64; 2], [f64; 2])], area: f64) -> NetworkStatistics {
    let frac: Vec<Fracture> = segments
        .iter()
        .map(|&(from, to)| Fracture {
            from,
            to,
            aperture: 1.0,
        })
        .collect();
    let len = |f: &Fracture| ((f.to[0] - f.from[0]).powi(2) + (f.to[1] - f.from[1]).powi(2)).sqrt();
    let lengths: Vec<f64> = frac.iter().map(len).collect();
    let mut degree = vec![0usize; frac.len()];
    let mut pairs = 0;
    for i in 0..frac.len() {
        for j in i + 1..frac.len() {
            let tol = 1e-9 * lengths[i].max(lengths[j]);
            if intersect(&frac[i], &frac[j], tol).is_some() {
                pairs += 1;
                degree[i] += 1;
                degree[j] += 1;
            }
        }
    }
    let total: f64 = lengths.iter().sum();
    let n = frac.len();
    NetworkStatistics {
        count: n,
        total_length: total,
        p21: total / area,
        intersections: pairs,
        intersections_per_fracture: if n > 0 {
            2.0 * pairs as f64 / n as f64
        } else {
            0.0
        },
        isolated: degree.iter().filter(|&&d| d == 0).count(),
        percolation_parameter: lengths.iter().map(|l| l * l).sum::<f64>() / area,
    }
}

/// The fluid pressure (Pa) at which a fracture from `from` to `to` (m) starts to slip under
/// the uniform stress `sxx`, `syy` (Pa, tension positive, no shear) by Coulomb's law with
/// friction angle `friction_deg`: tau = tan(phi) (sigma_c - p), where sigma_c = -n.sigma.n is
/// the normal compression and tau the resolved shear stress, so p = sigma_c - tau / tan(phi).
/// Negative where the fracture slips with no fluid at all (then it is critically stressed at
/// any pressure).
pub fn slip_pressure(from: [f64; 2], to: [f64; 2], sxx: f64, syy: f64, friction_deg: f64) -> f64 {
    let d = [to[0] - from[0], to[1] - from[1]];
    let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
    let (t, n) = ([d[0] / l, d[1] / l], [-d[1] / l, d[0] / l]);
    // Traction on the plane, sigma n, with sigma = diag(sxx, syy).
    let tr = [sxx * n[0], syy * n[1]];
    let sigma_n = tr[0] * n[0] + tr[1] * n[1];
    let tau = (tr[0] * t[0] + tr[1] * t[1]).abs();
    let mu = friction_deg.to_radians().tan();
    if mu > 0.0 {
        -sigma_n - tau / mu
    } else if tau > 0.0 {
        // No friction: any shear stress slips it.
        f64::NEG_INFINITY
    } else {
        -sigma_n
    }
}

impl NetworkSpec {
    /// All fractures: the explicit ones, then the generated ones.
    pub fn all_fractures(&self) -> Vec<Fracture> {
        let mut f = self.fractures.clone();
        if let Some(r) = &self.random {
            f.extend(r.generate());
        }
        f
    }

    pub fn validate(&self) -> Result<(), SetupError> {
        let bad = |f: &str, why: String| Err(SetupError::invalid(f, why));
        if !(self.cell_length.is_finite() && self.cell_length > 0.0) {
            return bad(
                "network.cell_length",
                format!("must be a finite number > 0, got {}", self.cell_length),
            );
        }
        for (i, f) in self.fractures.iter().enumerate() {
            let field = format!("network.fractures[{i}]");
            if !f.from.iter().chain(&f.to).all(|v| v.is_finite()) {
                return bad(&field, "end points must be finite".into());
            }
            if !(f.aperture.is_finite() && f.aperture > 0.0) {
                return bad(
                    &format!("{field}.aperture"),
                    format!("must be a finite number > 0, got {}", f.aperture),
                );
            }
            if f.from == f.to {
                return bad(&field, "has zero length".into());
            }
        }
        if let Some(r) = &self.random {
            r.validate_geometry("network.random")?;
            let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
            if !finite(&r.aperture) {
                let x = r.aperture.iter().find(|x| !x.is_finite()).expect("one");
                return bad(
                    "network.random.aperture",
                    format!("{x} is not a finite number"),
                );
            }
            if !(r.aperture[0] > 0.0 && r.aperture[1] >= r.aperture[0]) {
                return bad("network.random.aperture", "needs 0 < min <= max".into());
            }
        }
        let total =
            self.fractures.len() as f64 + self.random.as_ref().map_or(0.0, |r| r.count as f64);
        if total > MAX_FRACTURES as f64 {
            return bad(
                "network.random.count",
                format!(
                    "{total:.3e} fractures is more than the {} this engine takes (the \
                     intersection search compares every pair)",
                    MAX_FRACTURES
                ),
            );
        }
        if self.fractures.is_empty() && self.random.as_ref().is_none_or(|r| r.count == 0) {
            return bad("network", "has no fractures".into());
        }
        Ok(())
    }

    /// An upper estimate of the cells [`NetworkSpec::discretise`] makes, from the scenario
    /// alone (nothing generated): every fracture's length over `cell_length`, rounded up, plus
    /// two cells per intersection; a random family counts `count` fractures of the longest
    /// length (or the box diagonal, when shorter) and the expected intersections of as many
    /// random segments in the box, n^2 L^2 / (pi A). Infinite for non-finite input.
    pub fn cell_estimate(&self) -> f64 {
        let c = self.cell_length;
        let n = self.fractures.len() as f64;
        let mut cells: f64 = self
            .fractures
            .iter()
            .map(|f| {
                ((f.to[0] - f.from[0]).hypot(f.to[1] - f.from[1]) / c)
                    .ceil()
                    .max(1.0)
            })
            .sum();
        cells += n * (n - 1.0).max(0.0);
        if let Some(r) = &self.random {
            let m = r.count as f64;
            let diag = r.size[0].hypot(r.size[1]);
            let l = r.length[1].min(diag);
            cells += m * (l / c).ceil().max(1.0);
            let expected = m * m * l * l / (std::f64::consts::PI * r.size[0] * r.size[1]);
            cells += 2.0 * expected.min(0.5 * m * m) + 2.0 * m * n;
        }
        if cells.is_nan() { f64::INFINITY } else { cells }
    }

    /// Cut the fractures at their intersections and into cells of about `cell_length`.
    pub fn discretise(&self) -> CellNetwork {
        let fr = self.all_fractures();
        let scale = fr
            .iter()
            .flat_map(|f| {
                [
                    f.from[0].abs(),
                    f.from[1].abs(),
                    f.to[0].abs(),
                    f.to[1].abs(),
                ]
            })
            .fold(1.0, f64::max);
        let tol = 1e-9 * scale;
        let snap = (SNAP * self.cell_length).max(tol);
        // Break points along each fracture: (parameter, shared point id).
        let mut points: Vec<[f64; 2]> = Vec::new();
        let mut breaks: Vec<Vec<(f64, u32)>> = vec![Vec::new(); fr.len()];
        // Points within `snap` of an existing point reuse it: a hash grid of cell size `snap`
        // finds the candidates among the 3 x 3 neighbouring buckets.
        let mut grid: std::collections::HashMap<(i64, i64), Vec<u32>> =
            std::collections::HashMap::new();
        let key = |p: [f64; 2]| ((p[0] / snap).floor() as i64, (p[1] / snap).floor() as i64);
        let mut find_or_add = |p: [f64; 2], points: &mut Vec<[f64; 2]>| -> u32 {
            let (kx, ky) = key(p);
            let mut best: Option<(f64, u32)> = None;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for &k in grid.get(&(kx + dx, ky + dy)).map_or(&[][..], |v| &v[..]) {
                        let q = points[k as usize];
                        let d = (q[0] - p[0]).hypot(q[1] - p[1]);
                        if d <= snap && best.is_none_or(|b| (d, k) < b) {
                            best = Some((d, k));
                        }
                    }
                }
            }
            if let Some((_, k)) = best {
                return k;
            }
            points.push(p);
            let k = (points.len() - 1) as u32;
            grid.entry((kx, ky)).or_default().push(k);
            k
        };
        let project = |f: &Fracture, p: [f64; 2]| {
            let d = [f.to[0] - f.from[0], f.to[1] - f.from[1]];
            let t = ((p[0] - f.from[0]) * d[0] + (p[1] - f.from[1]) * d[1])
                / (d[0] * d[0] + d[1] * d[1]);
            t.clamp(0.0, 1.0)
        };
        for (i, f) in fr.iter().enumerate() {
            let a = find_or_add(f.from, &mut points);
            let b = find_or_add(f.to, &mut points);
            breaks[i].push((project(f, points[a as usize]), a));
            breaks[i].push((project(f, points[b as usize]), b));
        }
        for i in 0..fr.len() {
            for j in i + 1..fr.len() {
                if let Some((t, _)) = intersect(&fr[i], &fr[j], tol) {
                    let p = [
                        fr[i].from[0] + t * (fr[i].to[0] - fr[i].from[0]),
                        fr[i].from[1] + t * (fr[i].to[1] - fr[i].from[1]),
                    ];
                    let k = find_or_add(p, &mut points);
                    let q = points[k as usize];
                    breaks[i].push((project(&fr[i], q), k));
                    breaks[j].push((project(&fr[j], q), k));
                }
            }
        }
        let mut net = CellNetwork {
            nodes: points,
            cells: Vec::new(),
            fractures: fr.clone(),
        };
        for (fi, b) in breaks.iter_mut().enumerate() {
            b.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            b.dedup_by_key(|x| x.1);
            for w in b.windows(2) {
                let ((_, n0), (_, n1)) = (w[0], w[1]);
                if n0 == n1 {
                    continue;
                }
                // Cut between the actual (possibly snapped) end points.
                let (pa, pb) = (net.nodes[n0 as usize], net.nodes[n1 as usize]);
                let piece = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
                let m = (piece / self.cell_length - 1e-9).ceil().max(1.0) as usize;
                let mut prev = n0;
                for k in 1..=m {
                    let next = if k == m {
                        n1
                    } else {
                        let t = k as f64 / m as f64;
                        net.nodes
                            .push([pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1])]);
                        (net.nodes.len() - 1) as u32
                    };
                    net.cells.push((prev, next, fr[fi].aperture, fi as u32));
                    prev = next;
                }
            }
        }
        net
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frac(a: [f64; 2], b: [f64; 2]) -> Fracture {
        Fracture {
            from: a,
            to: b,
            aperture: 1e-4,
        }
    }

    #[test]
    fn single_fracture_cells() {
        let n = NetworkSpec {
            fractures: vec![frac([0.0, 0.0], [10.0, 0.0])],
            random: None,
            cell_length: 1.0,
        }
        .discretise();
        assert_eq!(n.cells.len(), 10);
        assert_eq!(n.nodes.len(), 11);
    }

    #[test]
    fn crossing_fractures_share_a_node() {
        let n = NetworkSpec {
            fractures: vec![frac([0.0, 0.0], [10.0, 0.0]), frac([5.0, -5.0], [5.0, 5.0])],
            random: None,
            cell_length: 1.0,
        }
        .discretise();
        assert_eq!(n.cells.len(), 20);
        let centre = n.nodes.iter().position(|p| p == &[5.0, 0.0]).unwrap() as u32;
        let at_centre = n
            .cells
            .iter()
            .filter(|c| c.0 == centre || c.1 == centre)
            .count();
        assert_eq!(at_centre, 4);
        // T junction: an end touching the other fracture.
        let t = NetworkSpec {
            fractures: vec![frac([0.0, 0.0], [10.0, 0.0]), frac([4.0, 0.0], [4.0, 6.0])],
            random: None,
            cell_length: 2.0,
        }
        .discretise();
        let j = t.nodes.iter().position(|p| p == &[4.0, 0.0]).unwrap() as u32;
        assert_eq!(t.cells.iter().filter(|c| c.0 == j || c.1 == j).count(), 3);
    }

    #[test]
    fn random_network_is_seeded_and_inside() {
        let r = RandomNetwork {
            seed: 5,
            count: 40,
            origin: [0.0, 0.0],
            size: [20.0, 10.0],
            angles_deg: vec![30.0, 120.0],
            jitter_deg: 10.0,
            length: [2.0, 8.0],
            aperture: [1e-4, 1e-3],
        };
        let a = r.generate();
        assert_eq!(a, r.generate());
        assert_eq!(a.len(), 40);
        for f in &a {
            for p in [f.from, f.to] {
                assert!(
                    p[0] >= -1e-12
                        && p[0] <= 20.0 + 1e-12
                        && p[1] >= -1e-12
                        && p[1] <= 10.0 + 1e-12
                );
            }
            assert!(f.aperture >= 1e-4 && f.aperture <= 1e-3);
        }
    }

    #[test]
    fn statistics_count_crossings_lengths_and_isolated_fractures() {
        // Two crossing 10 m segments and one 4 m segment apart, in a 20 m x 10 m box.
        let segs = [
            ([0.0, 5.0], [10.0, 5.0]),
            ([5.0, 0.0], [5.0, 10.0]),
            ([12.0, 1.0], [16.0, 1.0]),
        ];
        let s = statistics(&segs, 200.0);
        assert_eq!((s.count, s.intersections, s.isolated), (3, 1, 1));
        assert!((s.intersections_per_fracture - 2.0 / 3.0).abs() < 1e-15);
        assert!((s.total_length - 24.0).abs() < 1e-12);
        assert!((s.p21 - 0.12).abs() < 1e-15);
        assert!((s.percolation_parameter - 216.0 / 200.0).abs() < 1e-15);
        // A T (one ends on the other) counts as an intersection.
        let t = statistics(&[([0.0, 0.0], [2.0, 0.0]), ([1.0, 0.0], [1.0, 3.0])], 1.0);
        assert_eq!(t.intersections, 1);
    }

    #[test]
    fn slip_pressure_is_mohr_coulomb_on_the_fracture_plane() {
        // Mohr's circle: a plane whose normal makes beta with x under sxx = -20, syy = -10 MPa
        // carries sigma_c = 15 + 5 cos(2 beta) MPa (compression) and tau = 5 |sin(2 beta)|.
        let (sxx, syy) = (-20e6, -10e6);
        for deg in [0.0f64, 20.0, 45.0, 60.0, 100.0, 150.0] {
            let th = deg.to_radians();
            let beta = th + std::f64::consts::FRAC_PI_2;
            let (sc, tau) = (
                15e6 + 5e6 * (2.0 * beta).cos(),
                5e6 * (2.0 * beta).sin().abs(),
            );
            let want = sc - tau / 30f64.to_radians().tan();
            let got = slip_pressure([1.0, 2.0], [1.0 + th.cos(), 2.0 + th.sin()], sxx, syy, 30.0);
            assert!((got - want).abs() < 1e-6, "{deg} deg: {got} vs {want}");
        }
        // At 45 deg and 30 deg friction: 15 - 5 sqrt(3) MPa.
        let p = slip_pressure([0.0, 0.0], [1.0, 1.0], sxx, syy, 30.0);
        assert!((p - (15e6 - 5e6 * 3f64.sqrt())).abs() < 1e-6);
        // No friction: any shear slips; a principal plane never does.
        assert_eq!(
            slip_pressure([0.0, 0.0], [1.0, 1.0], sxx, syy, 0.0),
            f64::NEG_INFINITY
        );
        assert_eq!(slip_pressure([0.0, 0.0], [1.0, 0.0], sxx, syy, 0.0), 10e6);
    }
}
