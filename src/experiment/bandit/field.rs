//! The study's random fields (step 1 of the study, [`super`]): the grid with obstacles,
//! the true mean μ_l of every cell, the interesting cells and the stations and drones.

use super::StudyConfig;
use fleetmap_core::geo::Cell;
use fleetmap_core::planner::grid::PlannerGrid;
use rand::RngExt;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// One random field of the study — the planning grid with its true μ per cell, not a
/// rendered ground truth (that is [`fleetmap_core::world::World`]) — (or a fixed one, [`Field::default_10x10`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// G, O, R.
    pub grid: PlannerGrid,
    /// μ_l per dense cell index (0 for obstacles).
    pub(crate) mu: Vec<f64>,
    /// Whether each cell is interesting (μ_l ≥ θ).
    pub interesting: Vec<bool>,
    /// Station start cells.
    pub stations: Vec<usize>,
    /// Drone start cells (each on a station).
    pub drones: Vec<usize>,
}

/// Why a world cannot be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StudyError {
    /// The configuration cannot produce a world.
    #[error("impossible study configuration: {0}")]
    Config(String),
}

impl Field {
    /// Draw a world for `cfg` (see the module documentation).
    pub fn random(cfg: &StudyConfig, rng: &mut ChaCha8Rng) -> Result<Field, StudyError> {
        let n = cfg.rows * cfg.cols;
        if cfg.n_obstacles + cfg.nc.max(cfg.n_interesting) > n || cfg.nc == 0 || cfg.nd == 0 {
            return Err(StudyError::Config(format!(
                "{} obstacles, {} interesting cells and {} stations do not fit a {}×{} grid",
                cfg.n_obstacles, cfg.n_interesting, cfg.nc, cfg.rows, cfg.cols
            )));
        }
        for _ in 0..10_000 {
            let mut order: Vec<usize> = (0..n).collect();
            order.shuffle(rng);
            let cell = |i: usize| Cell::new((i / cfg.cols) as i32, (i % cfg.cols) as i32);
            let obstacles: Vec<Cell> = order[..cfg.n_obstacles].iter().map(|&i| cell(i)).collect();
            let grid = PlannerGrid::new(cfg.rows as i64, cfg.cols as i64, &obstacles, None)
                .map_err(|e| StudyError::Config(e.to_string()))?;
            if !grid.free_cells_connected() {
                continue;
            }
            let mut free = grid.free_cells();
            free.shuffle(rng);
            let mut interesting = vec![false; n];
            for &i in &free[..cfg.n_interesting] {
                interesting[i] = true;
            }
            let mut mu = vec![0.0; n];
            for i in grid.free_cells() {
                mu[i] = if interesting[i] {
                    rng.random_range(cfg.mu_worst..=1.0)
                } else {
                    rng.random_range(0.0..=1.0 - cfg.mu_worst)
                };
            }
            let mut st = grid.free_cells();
            st.shuffle(rng);
            let stations: Vec<usize> = st[..cfg.nc].to_vec();
            let drones = (0..cfg.nd).map(|i| stations[i % cfg.nc]).collect();
            let interesting = mu.iter().map(|&m| m >= cfg.theta).collect();
            return Ok(Field {
                grid,
                mu,
                interesting,
                stations,
                drones,
            });
        }
        Err(StudyError::Config(
            "no connected obstacle layout found in 10000 draws".into(),
        ))
    }

    /// The fixed 10×10 default of docs/fixtures.md (seed-2024 layout, in the IP scenario's top-left
    /// indexing: row r there is row 9 − r here), with μ drawn from `rng` as in §VI for
    /// μ_worst = `mu_worst`. Ten drones, two on each of the five stations.
    pub fn default_10x10(mu_worst: f64, theta: f64, rng: &mut ChaCha8Rng) -> Field {
        let flip = |v: &[(i32, i32)]| -> Vec<Cell> {
            v.iter().map(|&(r, c)| Cell::new(9 - r, c)).collect()
        };
        let obstacles = flip(&[
            (2, 3),
            (2, 5),
            (3, 1),
            (3, 3),
            (3, 8),
            (5, 2),
            (6, 0),
            (6, 8),
            (7, 4),
            (8, 1),
            (9, 1),
            (9, 2),
            (9, 3),
            (9, 4),
            (9, 6),
            (9, 7),
        ]);
        let interesting_cells = flip(&[
            (2, 9),
            (4, 4),
            (4, 7),
            (5, 0),
            (5, 9),
            (7, 1),
            (7, 5),
            (7, 6),
            (7, 8),
            (8, 8),
        ]);
        let station_cells = flip(&[(0, 9), (1, 8), (2, 8), (7, 3), (8, 7)]);
        // The fixture is valid by construction (checked by a unit test).
        let grid = PlannerGrid::new(10, 10, &obstacles, None).unwrap_or_else(|_| unreachable!());
        let idx = |c: Cell| grid.index(c).unwrap_or(0);
        let mut mu = vec![0.0; grid.len()];
        for i in grid.free_cells() {
            let interesting = interesting_cells.iter().any(|&c| idx(c) == i);
            mu[i] = if interesting {
                rng.random_range(mu_worst..=1.0)
            } else {
                rng.random_range(0.0..=1.0 - mu_worst)
            };
        }
        let stations: Vec<usize> = station_cells.iter().map(|&c| idx(c)).collect();
        let drones = (0..10).map(|i| stations[i / 2]).collect();
        Field {
            interesting: mu.iter().map(|&m| m >= theta).collect(),
            grid,
            mu,
            stations,
            drones,
        }
    }
}
