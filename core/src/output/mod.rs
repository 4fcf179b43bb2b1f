//! Output folder: ParaView frames (`frames/solid_NNNNN.vtu` and `solid.pvd`), `timeseries.csv`
//! and `summary.json`. Every file is written so that a crash leaves the earlier ones readable:
//! frames and the index are written to a temporary file and renamed, the time series is flushed
//! row by row, and `summary.json` is written last (the previous run's is removed at the start).
//! Every file is listed in the folder's manifest before it is written ([`folder`]): the next run
//! removes exactly those, never a file it did not write.

pub mod folder;
pub mod json;
pub mod plots;
pub mod vtk;

use crate::element::{SolidParams, cst_stress};
use crate::flow::FlowView;
use crate::network::Fracture;
use crate::scenario::Field;
use crate::view::SolidView;
use hydrofrac_components::CellKind;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

pub struct Outputs {
    pub dir: PathBuf,
    folder: folder::Folder,
    pvd: vtk::PvdWriter,
    network_pvd: vtk::PvdWriter,
    series: BufWriter<File>,
    /// `timeseries.csv`'s columns.
    columns: Vec<String>,
    /// Solid frames written.
    pub frames: usize,
    /// Network frames written.
    pub network_frames: usize,
    fields: Vec<Field>,
}

pub use crate::atomic::write as write_atomic;

impl Outputs {
    /// Prepare the folder `dir` ([`folder::Folder::prepare`]: a non-empty folder without a
    /// manifest is refused; the previous run's listed files are removed) and start the outputs.
    pub fn create(dir: &Path, fields: &[Field], columns: &[String]) -> std::io::Result<Self> {
        let f = folder::Folder::prepare(dir, false).map_err(std::io::Error::other)?;
        Self::new(f, fields, columns)
    }

    /// Start the outputs in a prepared folder: `timeseries.csv` with its header `columns`.
    pub fn new(
        folder: folder::Folder,
        fields: &[Field],
        columns: &[String],
    ) -> std::io::Result<Self> {
        let dir = folder.dir.clone();
        let ctx = |e: std::io::Error, what: &str| {
            std::io::Error::new(e.kind(), format!("cannot {what} {}: {e}", dir.display()))
        };
        let path = folder
            .claim("timeseries.csv")
            .map_err(|e| ctx(e, "write to output folder"))?;
        let mut series =
            BufWriter::new(File::create(path).map_err(|e| ctx(e, "write to output folder"))?);
        writeln!(series, "{}", columns.join(","))?;
        series.flush()?;
        Ok(Outputs {
            dir: dir.clone(),
            folder,
            pvd: vtk::PvdWriter::new(&dir.join("solid.pvd")),
            network_pvd: vtk::PvdWriter::new(&dir.join("network.pvd")),
            series,
            columns: columns.to_vec(),
            frames: 0,
            network_frames: 0,
            fields: fields.to_vec(),
        })
    }

    /// List `rel` (a `/`-separated path in the folder) in the manifest as this run's file and
    /// return its full path: every writer calls this just before it writes.
    pub fn claim(&self, rel: &str) -> std::io::Result<PathBuf> {
        self.folder.claim(rel)
    }

    /// The folder with its manifest (for writers that claim their own files).
    pub fn folder(&self) -> &folder::Folder {
        &self.folder
    }

    /// Append one `timeseries.csv` row (the values of the columns given at creation).
    /// A non-finite value is refused (`InvalidInput`, naming its column): a row holds a
    /// physical state or is not written.
    pub fn write_series(&mut self, values: &[f64]) -> std::io::Result<()> {
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "timeseries.csv: {} = {} (a row holds finite values only)",
                    self.columns.get(k).map_or("a column", String::as_str),
                    values[k]
                ),
            ));
        }
        let mut line = String::with_capacity(24 * values.len());
        for (k, v) in values.iter().enumerate() {
            if k > 0 {
                line.push(',');
            }
            line += &format!("{v:e}");
        }
        writeln!(self.series, "{line}")?;
        self.series.flush()
    }

    /// Write one ParaView frame of the network: cells as lines with pressure (Pa), aperture (m),
    /// flow rate (m^2/s), cell id and kind (0 pre-existing, 1 new).
    pub fn write_network_frame(&mut self, f: &FlowView, time: f64) -> std::io::Result<()> {
        let points: Vec<[f64; 3]> = f.node_pos.iter().map(|x| [x[0], x[1], 0.0]).collect();
        let conn: Vec<u32> = f.cell_nodes.as_flattened().to_vec();
        let id: Vec<f64> = f.cell_id.iter().map(|&i| i as f64).collect();
        let kind: Vec<f64> = f
            .kind
            .iter()
            .map(|k| if *k == CellKind::New { 1.0 } else { 0.0 })
            .collect();
        let arr = |name, values| vtk::DataArray {
            name,
            components: 1,
            values,
        };
        let joint: Vec<Vec<f64>> = (0..3)
            .map(|k| f.joint_stress.iter().map(|j| j[k]).collect())
            .collect();
        let mut cell_data = vec![
            arr("pressure", &f.pressure[..]),
            arr("aperture", &f.aperture[..]),
            arr("flow_rate", &f.flow_rate[..]),
            arr("cell_id", &id[..]),
            arr("kind", &kind[..]),
            arr("created_t", &f.created_t[..]),
        ];
        let kin: Vec<Vec<f64>> = (0..2)
            .map(|k| f.kinematics.iter().map(|j| j[k]).collect())
            .collect();
        if f.kinematics.len() == f.n_cells() && f.n_cells() > 0 {
            cell_data.push(arr("opening", &kin[0][..]));
            cell_data.push(arr("slip", &kin[1][..]));
        }
        if f.joint_stress.len() == f.n_cells() && f.n_cells() > 0 {
            cell_data.push(arr("joint_normal_stress", &joint[0][..]));
            cell_data.push(arr("joint_shear_stress", &joint[1][..]));
            cell_data.push(arr("sliding", &joint[2][..]));
        }
        self.write_network_piece(
            vtk::VtuPiece {
                points: &points,
                kind: vtk::CellKind::Line,
                connectivity: &conn,
                point_data: vec![],
                cell_data,
            },
            time,
        )
    }

    /// Write the next fracture-network frame `frames/network_NNNNN.vtu` and list it in
    /// `network.pvd` at `time`.
    fn write_network_piece(&mut self, piece: vtk::VtuPiece, time: f64) -> std::io::Result<()> {
        let name = format!("network_{:05}.vtu", self.network_frames);
        if self.network_frames == 0 {
            self.claim("network.pvd")?;
        }
        vtk::write_vtu(&self.claim(&format!("frames/{name}"))?, &piece)?;
        self.network_pvd.add(time, &format!("frames/{name}"))?;
        self.network_frames += 1;
        Ok(())
    }

    /// `network.csv`: one row per cell,
    /// `x0,y0,x1,y1,aperture,opening,slip,pressure,flow_rate,kind,created_t`: the hydraulic
    /// aperture, the joint's mechanical opening delta_n and shear slip delta_t (m; a cell
    /// without a joint: its aperture and 0), pressure (Pa), throughput (m^2/s), creation time (s).
    ///
    /// A table with a non-finite value (the state of a failed run) is not written: returns
    /// `Ok(false)` and writes nothing.
    pub fn write_network_csv(&self, f: &FlowView) -> std::io::Result<bool> {
        // x0, y0, x1, y1, aperture, opening, slip, pressure, flow_rate, created_t per cell.
        let rows: Vec<[f64; 10]> = (0..f.n_cells())
            .map(|c| {
                let kin = f.kinematics.get(c).copied().unwrap_or([f.aperture[c], 0.0]);
                let [a, b] = f.cell_nodes[c].map(|n| f.node_pos[n as usize]);
                [
                    a[0],
                    a[1],
                    b[0],
                    b[1],
                    f.aperture[c],
                    kin[0],
                    kin[1],
                    f.pressure[c],
                    f.flow_rate[c],
                    f.created_t[c],
                ]
            })
            .collect();
        if !rows.iter().flatten().all(|x| x.is_finite()) {
            return Ok(false);
        }
        let mut s =
            String::from("x0,y0,x1,y1,aperture,opening,slip,pressure,flow_rate,kind,created_t\n");
        for (c, r) in rows.iter().enumerate() {
            let kind = match f.kind[c] {
                CellKind::Preexisting => "preexisting",
                CellKind::New => "new",
            };
            s += &format!(
                "{},{},{},{},{},{},{},{},{},{},{}\n",
                r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], kind, r[9]
            );
        }
        write_atomic(&self.claim("network.csv")?, s.as_bytes())?;
        Ok(true)
    }

    /// `preexisting_fractures.csv`: the rock's pre-existing fractures as placed on the mesh,
    /// `x0,y0,x1,y1,snap_error,edges,snap_error_h,zigzag_deg` (m, m, mesh edges, 1, degrees):
    /// the input to reproduce a run or feed a network elsewhere, with how far the mesh path
    /// strays from each segment, absolutely and in mesh sizes, and the largest angle between
    /// a path edge and the segment.
    pub fn write_preexisting_csv(
        &self,
        placed: &[crate::fractures::Placed],
    ) -> std::io::Result<bool> {
        let finite = placed.iter().all(|p| {
            [
                p.from[0],
                p.from[1],
                p.to[0],
                p.to[1],
                p.snap_error,
                p.snap_error_h,
                p.zigzag_deg,
            ]
            .into_iter()
            .all(f64::is_finite)
        });
        if !finite {
            return Ok(false);
        }
        let mut s = String::from("x0,y0,x1,y1,snap_error,edges,snap_error_h,zigzag_deg\n");
        for p in placed {
            s += &format!(
                "{},{},{},{},{},{},{},{}\n",
                p.from[0],
                p.from[1],
                p.to[0],
                p.to[1],
                p.snap_error,
                p.edges,
                p.snap_error_h,
                p.zigzag_deg
            );
        }
        write_atomic(&self.claim("preexisting_fractures.csv")?, s.as_bytes())?;
        Ok(true)
    }

    /// `network_generated.csv`: the fractures the network was cut from, `x0,y0,x1,y1,aperture`.
    /// Like `network.csv`, not written (`Ok(false)`) when a value is not finite.
    pub fn write_fractures_csv(&self, fractures: &[Fracture]) -> std::io::Result<bool> {
        let finite = fractures.iter().all(|f| {
            [f.from[0], f.from[1], f.to[0], f.to[1], f.aperture]
                .into_iter()
                .all(f64::is_finite)
        });
        if !finite {
            return Ok(false);
        }
        let mut s = String::from("x0,y0,x1,y1,aperture\n");
        for f in fractures {
            s += &format!(
                "{},{},{},{},{}\n",
                f.from[0], f.from[1], f.to[0], f.to[1], f.aperture
            );
        }
        write_atomic(&self.claim("network_generated.csv")?, s.as_bytes())?;
        Ok(true)
    }

    /// Write one ParaView frame of the solid (reference positions; displacement to warp by).
    pub fn write_frame(
        &mut self,
        v: &SolidView,
        p: &SolidParams,
        poisson: f64,
        time: f64,
    ) -> std::io::Result<()> {
        let points: Vec<[f64; 3]> = v.x0.iter().map(|x| [x[0], x[1], 0.0]).collect();
        let conn: Vec<u32> = v.conn.as_flattened().to_vec();
        let disp: Vec<f64> = v.u.iter().flat_map(|u| [u[0], u[1], 0.0]).collect();
        let vel: Vec<f64> = v.v.iter().flat_map(|u| [u[0], u[1], 0.0]).collect();
        let node_id: Vec<f64> = v.node_id.iter().map(|&i| i as f64).collect();
        let elem_id: Vec<f64> = v.elem_id.iter().map(|&i| i as f64).collect();
        let stress: Vec<[f64; 3]> = v
            .conn
            .iter()
            .zip(&v.geom)
            .map(|(c, g)| cst_stress(g, c.map(|a| v.u[a as usize]), p))
            .collect();
        let comp = |k: usize| -> Vec<f64> { stress.iter().map(|s| s[k]).collect() };
        let (sxx, syy, sxy) = (comp(0), comp(1), comp(2));
        let szz: Vec<f64> = stress.iter().map(|s| poisson * (s[0] + s[1])).collect();
        let mut cell_data = vec![arr("element_id", 1, &elem_id[..])];
        if self.fields.contains(&Field::Stress) {
            cell_data.push(arr("stress_xx", 1, &sxx[..]));
            cell_data.push(arr("stress_yy", 1, &syy[..]));
            cell_data.push(arr("stress_xy", 1, &sxy[..]));
            cell_data.push(arr("stress_zz", 1, &szz[..]));
        }
        self.write_solid_piece(
            vtk::VtuPiece {
                points: &points,
                kind: vtk::CellKind::Triangle,
                connectivity: &conn,
                point_data: self.solid_point_data(&node_id, &disp, &vel),
                cell_data,
            },
            time,
        )
    }

    /// A solid frame's point data: the node ids, and the displacement and velocity (three
    /// components each, m and m/s) when the scenario's fields ask for them.
    fn solid_point_data<'a>(
        &self,
        node_id: &'a [f64],
        disp: &'a [f64],
        vel: &'a [f64],
    ) -> Vec<vtk::DataArray<'a>> {
        let mut point_data = vec![arr("node_id", 1, node_id)];
        if self.fields.contains(&Field::Displacement) {
            point_data.push(arr("displacement", 3, disp));
        }
        if self.fields.contains(&Field::Velocity) {
            point_data.push(arr("velocity", 3, vel));
        }
        point_data
    }

    /// Write the next solid frame `frames/solid_NNNNN.vtu` and list it in `solid.pvd` at
    /// `time` (s).
    fn write_solid_piece(&mut self, piece: vtk::VtuPiece, time: f64) -> std::io::Result<()> {
        let name = format!("solid_{:05}.vtu", self.frames);
        if self.frames == 0 {
            self.claim("solid.pvd")?;
        }
        vtk::write_vtu(&self.claim(&format!("frames/{name}"))?, &piece)?;
        self.pvd.add(time, &format!("frames/{name}"))?;
        self.frames += 1;
        Ok(())
    }

    /// Write one ParaView frame of the 3D rock: tetrahedra with displacement and velocity (m,
    /// m/s) at the nodes and the six stress components (Pa, tension positive) per element.
    pub fn write_frame_3d(
        &mut self,
        v: &SolidView<crate::dim::Tet4>,
        p: &SolidParams,
        time: f64,
    ) -> std::io::Result<()> {
        use crate::dim::{Element, Tet4};
        let conn: Vec<u32> = v.conn.as_flattened().to_vec();
        let disp: Vec<f64> = v.u.as_flattened().to_vec();
        let vel: Vec<f64> = v.v.as_flattened().to_vec();
        let node_id: Vec<f64> = v.node_id.iter().map(|&i| i as f64).collect();
        let elem_id: Vec<f64> = v.elem_id.iter().map(|&i| i as f64).collect();
        let stress: Vec<[f64; 6]> = (0..v.n_elems())
            .map(|k| Tet4::stress(&v.geom[k], &v.conn[k], &v.u, p))
            .collect();
        let comp: Vec<Vec<f64>> = (0..6)
            .map(|k| stress.iter().map(|s| s[k]).collect())
            .collect();
        let mut cell_data = vec![arr("element_id", 1, &elem_id[..])];
        if self.fields.contains(&Field::Stress) {
            for (name, values) in STRESS_NAMES.iter().zip(&comp) {
                cell_data.push(arr(name, 1, &values[..]));
            }
        }
        self.write_solid_piece(
            vtk::VtuPiece {
                points: &v.x0,
                kind: vtk::CellKind::Tetra,
                connectivity: &conn,
                point_data: self.solid_point_data(&node_id, &disp, &vel),
                cell_data,
            },
            time,
        )
    }
}

impl Outputs {
    /// Write one ParaView frame of the 3D fracture surfaces, `frames/network_NNNNN.vtu` in
    /// `network.pvd` (the 2D network's files): one triangle per joint at face p's reference
    /// place, with the joint's opening delta_n and slip |delta_t| (m), its normal and shear
    /// stress (compression positive, |F_t|; Pa: the force over A0), whether it slides, its
    /// face pressure `pressure[k]` (Pa) and, with flow, its cell's hydraulic aperture
    /// `aperture[k]` (m; no column when `aperture` is empty).
    pub fn write_fracture_3d(
        &mut self,
        v: &SolidView<crate::dim::Tet4>,
        pressure: &[f64],
        aperture: &[f64],
        time: f64,
    ) -> std::io::Result<()> {
        use crate::model3::{joint_area0_3d, joint_frame_3d};
        let nj = v.joint_nodes.len();
        let mut points = Vec::with_capacity(3 * nj);
        let mut cols: [Vec<f64>; 7] = Default::default();
        for k in 0..nj {
            for a in 0..3 {
                points.push(v.x0[v.joint_nodes[k][a] as usize]);
            }
            let f = joint_frame_3d(v, k);
            let a0 = joint_area0_3d(v, k);
            let st = &v.joint_state[k];
            let row = [
                f.dn,
                f.dt[0].hypot(f.dt[1]),
                st.normal_force / a0,
                {
                    let f = crate::model3::face_shear(st);
                    f[0].hypot(f[1]) / a0
                },
                f64::from(u8::from(st.sliding)),
                pressure[k],
                aperture.get(k).copied().unwrap_or(0.0),
            ];
            for (c, x) in cols.iter_mut().zip(row) {
                c.push(x);
            }
        }
        let conn: Vec<u32> = (0..3 * nj as u32).collect();
        let names = [
            "opening",
            "slip",
            "joint_normal_stress",
            "joint_shear_stress",
            "sliding",
            "pressure",
            "aperture",
        ];
        // The hydraulic aperture only with flow.
        let shown = if aperture.is_empty() { 6 } else { 7 };
        let cell_data = names[..shown]
            .iter()
            .zip(&cols)
            .map(|(n, c)| arr(n, 1, &c[..]))
            .collect();
        self.write_network_piece(
            vtk::VtuPiece {
                points: &points,
                kind: vtk::CellKind::Triangle,
                connectivity: &conn,
                point_data: vec![],
                cell_data,
            },
            time,
        )
    }
}

/// A named array of `components` values per point or cell.
fn arr<'a>(name: &'a str, components: usize, values: &'a [f64]) -> vtk::DataArray<'a> {
    vtk::DataArray {
        name,
        components,
        values,
    }
}

/// The 3D frame's stress arrays, in Voigt order.
const STRESS_NAMES: [&str; 6] = [
    "stress_xx",
    "stress_yy",
    "stress_zz",
    "stress_xy",
    "stress_yz",
    "stress_zx",
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Two cells; `p1` is the second one's pressure.
    fn view(p1: f64) -> FlowView {
        FlowView {
            node_pos: vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]],
            cell_nodes: vec![[0, 1], [1, 2]],
            aperture: vec![1e-3, 1e-3],
            pressure: vec![1e6, p1],
            flow_rate: vec![0.0, 0.0],
            kind: vec![CellKind::Preexisting, CellKind::New],
            created_t: vec![0.0, 0.1],
            cell_entity: vec![hecs::Entity::DANGLING; 2],
            ..Default::default()
        }
    }

    /// The state of a failed run (a NaN pressure) gives no `network.csv`, and nothing is listed
    /// in the manifest for it; a finite state gives the table.
    #[test]
    fn network_csv_with_a_non_finite_value_is_not_written() {
        let dir = std::env::temp_dir().join(format!("hydrofrac-netcsv-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let out = Outputs::create(&dir, &[], &["step".into()]).unwrap();
        assert!(!out.write_network_csv(&view(f64::NAN)).unwrap());
        assert!(!dir.join("network.csv").exists());
        let manifest = std::fs::read_to_string(dir.join(folder::MANIFEST)).unwrap();
        assert!(!manifest.contains("network.csv"));
        assert!(out.write_network_csv(&view(2e6)).unwrap());
        let csv = std::fs::read_to_string(dir.join("network.csv")).unwrap();
        assert_eq!(csv.lines().count(), 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
