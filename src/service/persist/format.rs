//! The checkpoint payload, format 5: structs of its own, converted from and to the core's plain-data
//! states (`VehicleSnapshot`, `FilterState`, `AhrsState`, …). The layout is bincode (fixed-width
//! little-endian integers, `f64` as IEEE bits, lengths as `u64`) of the structs below, field by field in
//! the order written here; vectors are `[x, y, z]`, quaternions `[x, y, z, w]` (scalar last, the
//! core's order), matrices row by row.
//!
//! Each struct is declared by [`saved!`], which also converts it: the conversion destructures the core
//! type without `..`, so a field added to the core does not compile until it is added here, and a
//! change here changes the golden checkpoint test's bytes (`tests/it/checkpoint_golden.rs`): the format
//! never changes by accident.

use super::SavedCounters;
use crate::ahrs::repeats::{Interpolation, MagHold};
use crate::ahrs::rest::RestDetector;
use crate::ahrs::{AhrsCounts, AhrsState, NoiseMeter, Output, Phase, SensorSheet};
use crate::attitude::{Grp, Quaternion};
use crate::filters::qpf::Cloud;
use crate::filters::sghqf::Points;
use crate::filters::usque::{SigmaPoints, N_SIGMA};
use crate::filters::{
    Diagnostics, DriverState, Estimate, Fiducial, FilterConfig, FilterKind, FilterSpec,
    FilterState, GapModel, GyroErrors, Kernel, MekfState, QpfOptions, QpfState, SghqfState,
    UsqueOptions, UsqueState,
};
use crate::sensors::field::{FieldChannel, HardIronFit, HardIronSolution};
use crate::sensors::gravity::{GravityChannel, LowpassState};
use crate::sensors::gyro::GyroChannel;
use crate::sensors::lowpass::Lowpass3;
use crate::sensors::model::SensorState;
use crate::sensors::{
    Aspect, GyroNoise, GyroSample, ImuSample, Measurement, ObservationSet, VectorObservation,
};
use crate::vehicle::policy::{InitMode, VehicleFilterConfig};
use crate::vehicle::{GateCounts, HeldSample, JumpCandidate, Stream, VehicleSnapshot};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A core value and its checkpoint form.
pub trait Saved: Sized {
    type Form: Serialize + for<'de> Deserialize<'de>;
    fn save(&self) -> Self::Form;
    /// `Err` says what in the checkpoint cannot be this value.
    fn load(form: Self::Form) -> Result<Self, String>;
}

macro_rules! as_is {
    ($($t:ty),*) => {$(
        impl Saved for $t {
            type Form = $t;
            fn save(&self) -> $t { self.clone() }
            fn load(form: $t) -> Result<$t, String> { Ok(form) }
        }
    )*};
}
as_is!(f64, u64, u32, u8, bool, String);

impl Saved for usize {
    type Form = u64;
    fn save(&self) -> u64 {
        *self as u64
    }
    fn load(form: u64) -> Result<usize, String> {
        usize::try_from(form).map_err(|_| format!("{form} does not fit this machine's usize"))
    }
}

impl<T: Saved> Saved for Option<T> {
    type Form = Option<T::Form>;
    fn save(&self) -> Self::Form {
        self.as_ref().map(T::save)
    }
    fn load(form: Self::Form) -> Result<Self, String> {
        form.map(T::load).transpose()
    }
}

impl<T: Saved> Saved for Vec<T> {
    type Form = Vec<T::Form>;
    fn save(&self) -> Self::Form {
        self.iter().map(T::save).collect()
    }
    fn load(form: Self::Form) -> Result<Self, String> {
        form.into_iter().map(T::load).collect()
    }
}

impl<T: Saved> Saved for BTreeMap<String, T> {
    type Form = BTreeMap<String, T::Form>;
    fn save(&self) -> Self::Form {
        self.iter().map(|(k, v)| (k.clone(), v.save())).collect()
    }
    fn load(form: Self::Form) -> Result<Self, String> {
        form.into_iter()
            .map(|(k, v)| Ok((k, T::load(v)?)))
            .collect()
    }
}

impl<A: Saved, B: Saved> Saved for (A, B) {
    type Form = (A::Form, B::Form);
    fn save(&self) -> Self::Form {
        (self.0.save(), self.1.save())
    }
    fn load(form: Self::Form) -> Result<Self, String> {
        Ok((A::load(form.0)?, B::load(form.1)?))
    }
}

impl<T: Saved, const N: usize> Saved for [T; N]
where
    [T::Form; N]: Serialize + for<'de> Deserialize<'de>,
{
    type Form = [T::Form; N];
    fn save(&self) -> Self::Form {
        std::array::from_fn(|i| self[i].save())
    }
    fn load(form: Self::Form) -> Result<Self, String> {
        let v: Vec<T> = form.into_iter().map(T::load).collect::<Result<_, _>>()?;
        v.try_into().map_err(|_| "array length".to_string())
    }
}

impl Saved for Vector3<f64> {
    type Form = [f64; 3];
    fn save(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
    fn load(f: [f64; 3]) -> Result<Self, String> {
        Ok(Vector3::from(f))
    }
}

impl Saved for Vector6<f64> {
    type Form = [f64; 6];
    fn save(&self) -> [f64; 6] {
        std::array::from_fn(|i| self[i])
    }
    fn load(f: [f64; 6]) -> Result<Self, String> {
        Ok(Vector6::from(f))
    }
}

impl Saved for Matrix3<f64> {
    type Form = [[f64; 3]; 3];
    fn save(&self) -> Self::Form {
        std::array::from_fn(|r| std::array::from_fn(|c| self[(r, c)]))
    }
    fn load(f: Self::Form) -> Result<Self, String> {
        Ok(Matrix3::from_fn(|r, c| f[r][c]))
    }
}

impl Saved for Matrix6<f64> {
    type Form = [[f64; 6]; 6];
    fn save(&self) -> Self::Form {
        std::array::from_fn(|r| std::array::from_fn(|c| self[(r, c)]))
    }
    fn load(f: Self::Form) -> Result<Self, String> {
        Ok(Matrix6::from_fn(|r, c| f[r][c]))
    }
}

impl Saved for Quaternion {
    type Form = [f64; 4];
    fn save(&self) -> [f64; 4] {
        [self.x, self.y, self.z, self.w]
    }
    fn load(f: [f64; 4]) -> Result<Self, String> {
        Ok(Quaternion::new(f[0], f[1], f[2], f[3]))
    }
}

/// `saved! { Form for Core { field: Type, … } }`: the checkpoint struct `Form` with one field per
/// field of `Core` (each in its own checkpoint form), and the conversions both ways.
macro_rules! saved {
    ($(#[$m:meta])* $form:ident for $core:ident { $($f:ident: $t:ty),* $(,)? }) => {
        $(#[$m])*
        #[derive(Serialize, Deserialize)]
        pub struct $form {
            $($f: <$t as Saved>::Form),*
        }

        impl Saved for $core {
            type Form = $form;
            fn save(&self) -> $form {
                let $core { $($f),* } = self;
                $form { $($f: <$t as Saved>::save($f)),* }
            }
            fn load(form: $form) -> Result<Self, String> {
                Ok($core { $($f: <$t as Saved>::load(form.$f)?),* })
            }
        }
    };
}

/// `unit_enum! { Form for Core { A, B } }`: a field-less enum saved by variant.
macro_rules! unit_enum {
    ($form:ident for $core:ident { $($v:ident),* $(,)? }) => {
        #[derive(Serialize, Deserialize)]
        pub enum $form { $($v),* }

        impl Saved for $core {
            type Form = $form;
            fn save(&self) -> $form {
                match self { $($core::$v => $form::$v),* }
            }
            fn load(form: $form) -> Result<Self, String> {
                Ok(match form { $($form::$v => $core::$v),* })
            }
        }
    };
}

unit_enum!(KindV5 for FilterKind { Mekf, Usque, Qpf, Sghqf });
unit_enum!(FiducialV5 for Fiducial { Propagated, Average });
unit_enum!(KernelV5 for Kernel { Gaussian, Epanechnikov });
unit_enum!(InitModeV5 for InitMode { Vectors, Uniform });
unit_enum!(StreamV5 for Stream { Gyro, Vectors, Imu });

saved!(SpecV5 for FilterSpec { kind: FilterKind, fiducial: Option<Fiducial> });
saved!(GyroNoiseV5 for GyroNoise { sigma_v: f64, sigma_u: f64 });
saved!(GrpV5 for Grp { a: f64, f: f64 });
saved!(QpfOptionsV5 for QpfOptions {
    kernel: Kernel,
    bandwidth_scale: f64,
    resample_fraction: f64,
    pc_spread: f64,
    pc_max_stages: u32,
    inflation: f64,
});
saved!(UsqueOptionsV5 for UsqueOptions { grp: Grp, lambda: f64 });
saved!(GapV5 for GapModel { after_s: f64, accel_sigma_rad_s2: f64 });
saved!(GyroErrorsV5 for GyroErrors { rate_noise_sqrt_s: f64, bias_limit_rad_s: f64 });
saved!(FilterConfigV5 for FilterConfig {
    spec: FilterSpec,
    gyro: GyroNoise,
    particles: usize,
    level: u8,
    qpf: QpfOptions,
    usque: UsqueOptions,
    gap: GapModel,
    gyro_errors: GyroErrors,
});
saved!(
    /// The vehicle's filter configuration (a reset may have changed it from the service's).
    VehicleConfigV5 for VehicleFilterConfig {
        filter: FilterConfig,
        init: InitMode,
        init_bias_sigma_rad_s: Vector3<f64>,
        sensor: SensorSheet,
    }
);
saved!(SensorSheetV10 for SensorSheet {
    gyro_noise_density_deg_s_sqrt_hz: f64,
    gyro_bias_instability_deg_h: f64,
    gyro_range_deg_s: f64,
    acc_noise_density_ug_sqrt_hz: f64,
    acc_range_g: f64,
    mag_noise: f64,
    mag_offset_sigma: f64,
    output: Output,
});
unit_enum!(OutputV8 for Output { Unstated, Mean, Increments, Instant });
saved!(NoiseMeterV5 for NoiseMeter {
    gyro_var: f64,
    acc_var: f64,
    mag_var: f64,
    dt_s: f64,
    rest_s: f64,
    last_mag: Option<Vector3<f64>>,
});

// Measurements held in the reorder window.
saved!(GyroSampleV5 for GyroSample { t_s: f64, omega_body_rad_s: Vector3<f64> });
saved!(ObservationV5 for VectorObservation {
    body: Vector3<f64>,
    reference: Vector3<f64>,
    sigma: f64,
    sensor: Option<String>,
    aspect: Aspect,
});
saved!(ObservationSetV5 for ObservationSet { t_s: f64, observations: Vec<VectorObservation> });
saved!(ImuSampleV5 for ImuSample {
    t_s: f64,
    gyr_rad_s: Vector3<f64>,
    acc_m_s2: Vector3<f64>,
    mag: Option<Vector3<f64>>,
});

#[derive(Serialize, Deserialize)]
pub enum AspectV5 {
    Full,
    Heading([f64; 3]),
    Tilt([f64; 3]),
}

impl Saved for Aspect {
    type Form = AspectV5;
    fn save(&self) -> AspectV5 {
        match self {
            Aspect::Full => AspectV5::Full,
            Aspect::Heading(v) => AspectV5::Heading(v.save()),
            Aspect::Tilt(v) => AspectV5::Tilt(v.save()),
        }
    }
    fn load(f: AspectV5) -> Result<Self, String> {
        Ok(match f {
            AspectV5::Full => Aspect::Full,
            AspectV5::Heading(v) => Aspect::Heading(Vector3::load(v)?),
            AspectV5::Tilt(v) => Aspect::Tilt(Vector3::load(v)?),
        })
    }
}

#[derive(Serialize, Deserialize)]
pub enum MeasurementV5 {
    Gyro(GyroSampleV5),
    Vectors(ObservationSetV5),
    Imu(ImuSampleV5),
}

impl Saved for Measurement {
    type Form = MeasurementV5;
    fn save(&self) -> MeasurementV5 {
        match self {
            Measurement::Gyro(g) => MeasurementV5::Gyro(g.save()),
            Measurement::Vectors(s) => MeasurementV5::Vectors(s.save()),
            Measurement::Imu(s) => MeasurementV5::Imu(s.save()),
        }
    }
    fn load(f: MeasurementV5) -> Result<Self, String> {
        Ok(match f {
            MeasurementV5::Gyro(g) => Measurement::Gyro(GyroSample::load(g)?),
            MeasurementV5::Vectors(s) => Measurement::Vectors(ObservationSet::load(s)?),
            MeasurementV5::Imu(s) => Measurement::Imu(ImuSample::load(s)?),
        })
    }
}

// Filters.
saved!(DiagnosticsV5 for Diagnostics {
    propagations: u64,
    updates: u64,
    nis: Option<f64>,
    nis_dof: Option<usize>,
    ess: Option<f64>,
    concentration: Option<f64>,
    eigen_gap: Option<f64>,
    pc_stages: Option<u32>,
    resamples: Option<u64>,
    fiducial_fallbacks: Option<u64>,
    gyro_gap_s: Option<f64>,
    gyro_gaps: u64,
});
saved!(EstimateV5 for Estimate {
    t_s: f64,
    q: Quaternion,
    bias_rad_s: Vector3<f64>,
    covariance: Matrix6<f64>,
    diagnostics: Diagnostics,
});
saved!(DriverV5 for DriverState {
    t_s: Option<f64>,
    omega_meas_rad_s: Option<Vector3<f64>>,
    last_gyro_t_s: Option<f64>,
    last_gyro_dt_s: f64,
    gyro_intervals: u64,
    gap: GapModel,
    sigma_v: f64,
    gyro_gaps: u64,
});
saved!(MekfV5 for MekfState {
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    q: Quaternion,
    bias: Vector3<f64>,
    p: Matrix6<f64>,
    diagnostics: Diagnostics,
});
saved!(SigmaPointsV5 for SigmaPoints { q: [Quaternion; N_SIGMA], chi: [Vector6<f64>; N_SIGMA] });
saved!(UsqueV5 for UsqueState {
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    options: UsqueOptions,
    fiducial: Fiducial,
    q_ref: Quaternion,
    x: Vector6<f64>,
    p: Matrix6<f64>,
    sigma: Option<SigmaPoints>,
    diagnostics: Diagnostics,
});
saved!(
    /// The propagated points (one per point of the level's rule; `restore` checks the count).
    PointsV5 for Points { q: Vec<Quaternion>, chi: Vec<Vector6<f64>> }
);
saved!(SghqfV5 for SghqfState {
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    level: u8,
    fiducial: Fiducial,
    q_ref: Quaternion,
    x: Vector6<f64>,
    p: Matrix6<f64>,
    points: Option<Points>,
    diagnostics: Diagnostics,
});
saved!(
    /// The particles, structure of arrays.
    CloudV5 for Cloud {
        qx: Vec<f64>,
        qy: Vec<f64>,
        qz: Vec<f64>,
        qw: Vec<f64>,
        bx: Vec<f64>,
        by: Vec<f64>,
        bz: Vec<f64>,
        w: Vec<f64>,
    }
);
saved!(
    /// `rng` is the Xoshiro256++ state: a restored filter draws what the saved one would have.
    QpfV5 for QpfState {
        fiducial: Fiducial,
        options: QpfOptions,
        gyro: GyroNoise,
        gyro_errors: GyroErrors,
        cloud: Cloud,
        q_prop: Quaternion,
        q_hat: Quaternion,
        beta_hat: Vector3<f64>,
        p_hat: Matrix6<f64>,
        stale: bool,
        rng: [u64; 4],
        diagnostics: Diagnostics,
    }
);

#[derive(Serialize, Deserialize)]
// Made once per checkpoint, never stored in bulk: the size of the largest variant costs nothing.
#[allow(clippy::large_enum_variant)]
pub enum FilterV5 {
    Mekf(DriverV5, MekfV5),
    Usque(DriverV5, UsqueV5),
    Qpf(DriverV5, QpfV5),
    Sghqf(DriverV5, SghqfV5),
}

impl Saved for FilterState {
    type Form = FilterV5;
    fn save(&self) -> FilterV5 {
        match self {
            FilterState::Mekf(d, s) => FilterV5::Mekf(d.save(), s.save()),
            FilterState::Usque(d, s) => FilterV5::Usque(d.save(), s.save()),
            FilterState::Qpf(d, s) => FilterV5::Qpf(d.save(), s.save()),
            FilterState::Sghqf(d, s) => FilterV5::Sghqf(d.save(), s.save()),
        }
    }
    fn load(f: FilterV5) -> Result<Self, String> {
        Ok(match f {
            FilterV5::Mekf(d, s) => FilterState::Mekf(DriverState::load(d)?, MekfState::load(s)?),
            FilterV5::Usque(d, s) => {
                FilterState::Usque(DriverState::load(d)?, UsqueState::load(s)?)
            }
            FilterV5::Qpf(d, s) => FilterState::Qpf(DriverState::load(d)?, QpfState::load(s)?),
            FilterV5::Sghqf(d, s) => {
                FilterState::Sghqf(DriverState::load(d)?, SghqfState::load(s)?)
            }
        })
    }
}

// The raw-IMU pipeline.
saved!(Lowpass3V5 for Lowpass3 {
    tau_s: f64,
    dt_s: f64,
    c: [f64; 5],
    x: [Vector3<f64>; 2],
    y: Option<[Vector3<f64>; 2]>,
});
saved!(RestV9 for RestDetector {
    gyr_lp: Lowpass3,
    acc_lp: Lowpass3,
    gyr_dev: Vector3<f64>,
    acc_dev: Vector3<f64>,
    still_s: f64,
    at_rest: bool,
});
saved!(GravityV5 for GravityChannel {
    lp: Lowpass3,
    lp2: Lowpass3,
    motion_ms: f64,
    frame_var: f64,
    g0: f64,
    since_update_s: f64,
    sigma_lp_rad: f64,
});
saved!(HardIronSolutionV5 for HardIronSolution {
    field_gyro: Vector3<f64>,
    offset: Vector3<f64>,
    residual_rms: f64,
    offset_sigma: f64,
});
/// The hard-iron fit as the format keeps it: the dense normal matrix `Σ λ HᵀH`, which the core holds
/// on its structure `[[n I, Jᵀ], [J, n I]]` (`HardIronFit::info`; a matrix without it is refused).
#[derive(Serialize, Deserialize)]
pub struct HardIronFitV5 {
    info: <Matrix6<f64> as Saved>::Form,
    rhs: <Vector6<f64> as Saved>::Form,
    ss: f64,
    n: f64,
    recent_ms: f64,
    solution: <Option<HardIronSolution> as Saved>::Form,
}

impl Saved for HardIronFit {
    type Form = HardIronFitV5;
    fn save(&self) -> HardIronFitV5 {
        let HardIronFit {
            j: _,
            rhs,
            ss,
            n,
            recent_ms,
            solution,
        } = self;
        HardIronFitV5 {
            info: self.info().save(),
            rhs: rhs.save(),
            ss: *ss,
            n: *n,
            recent_ms: *recent_ms,
            solution: solution.save(),
        }
    }
    fn load(form: HardIronFitV5) -> Result<Self, String> {
        let info = Matrix6::load(form.info)?;
        Ok(HardIronFit {
            j: HardIronFit::j_of_info(&info, form.n)?,
            rhs: Vector6::load(form.rhs)?,
            ss: form.ss,
            n: form.n,
            recent_ms: form.recent_ms,
            solution: Option::load(form.solution)?,
        })
    }
}
saved!(FieldV5 for FieldChannel {
    direction: Vector3<f64>,
    norm: f64,
    dip: f64,
    offset: Vector3<f64>,
    offset_sigma: f64,
    lp_norm: f64,
    lp_dip: f64,
    lp_ready: bool,
    disturbed: bool,
    undisturbed_s: f64,
    rejected_s: f64,
    candidate_norm: f64,
    candidate_dip: f64,
    candidate_s: f64,
    fit: HardIronFit,
    fit_ok_s: f64,
    since_update_s: f64,
    since_solve_s: f64,
    new_fields: u64,
    hard_iron_changes: u64,
    confirmed: bool,
});
saved!(AhrsCountsV5 for AhrsCounts {
    samples: u64,
    at_rest: bool,
    rest_samples: u64,
    bias_updates: u64,
    tilt_updates: u64,
    tilt_gated: u64,
    heading_updates: u64,
    mag_disturbed: bool,
    mag_rejected: u64,
    mag_new_fields: u64,
    mag_hard_iron_changes: u64,
    tilt_reacquisitions: u64,
    heading_reacquisitions: u64,
    tilt_sigma_lp_rad: f64,
    gyro_saturated: u64,
    acc_saturated: u64,
    heading_unaided_s: f64,
    gaps: u64,
    blind_s: f64,
});
saved!(GyroChannelV5 for GyroChannel {
    previous: Option<Vector3<f64>>,
    largest: f64,
    clipped: bool,
    clip_repeats: u32,
    run: u32,
    saturated: u64,
    interval_s: f64,
    rate_ms: f64,
    change_ms: f64,
    gaps: u64,
    blind_s: f64,
    held: u32,
});

#[derive(Serialize, Deserialize)]
pub enum PhaseV5 {
    Aligning {
        t0_s: f64,
        acc: [f64; 3],
        mag: [f64; 3],
        n_acc: u32,
        n_mag: u32,
    },
    Running,
}

impl Saved for Phase {
    type Form = PhaseV5;
    fn save(&self) -> PhaseV5 {
        match *self {
            Phase::Aligning {
                t0_s,
                acc,
                mag,
                n_acc,
                n_mag,
            } => PhaseV5::Aligning {
                t0_s,
                acc: acc.save(),
                mag: mag.save(),
                n_acc,
                n_mag,
            },
            Phase::Running => PhaseV5::Running,
        }
    }
    fn load(f: PhaseV5) -> Result<Self, String> {
        Ok(match f {
            PhaseV5::Aligning {
                t0_s,
                acc,
                mag,
                n_acc,
                n_mag,
            } => Phase::Aligning {
                t0_s,
                acc: Vector3::load(acc)?,
                mag: Vector3::load(mag)?,
                n_acc,
                n_mag,
            },
            PhaseV5::Running => Phase::Running,
        })
    }
}

saved!(InterpolationV7 for Interpolation {
    last_gyr: Option<Vector3<f64>>,
    last_acc: Option<Vector3<f64>>,
    last_mag: Option<Vector3<f64>>,
    change_gyr: Option<Vector3<f64>>,
    change_acc: Option<Vector3<f64>>,
    change_mag: Option<Vector3<f64>>,
    run: u32,
    blind_s: f64,
});
saved!(MagHoldV7 for MagHold {
    last_raw: Option<Vector3<f64>>,
    fresh: Option<Vector3<f64>>,
    fresh_frame: Option<Matrix3<f64>>,
});

saved!(AhrsV10 for AhrsState {
    phase: Phase,
    t_s: Option<f64>,
    q_gyro: Quaternion,
    sheet: SensorSheet,
    noise: NoiseMeter,
    gyro: GyroChannel,
    rest: RestDetector,
    gravity: GravityChannel,
    field: Option<FieldChannel>,
    since_bias_s: f64,
    published: Matrix3<f64>,
    north_var: f64,
    tilt_inconsistent_s: f64,
    heading_inconsistent_s: f64,
    counts: AhrsCounts,
    line: Interpolation,
    mag_hold: MagHold,
});

// The vehicle.
saved!(GateCountsV5 for GateCounts { accepted: u64, gated: u64, norm_gated: u64, disturbed: u64 });
saved!(LowpassStateV5 for LowpassState {
    t_s: Option<f64>,
    body_frame: Vector3<f64>,
    posterior: Option<Quaternion>,
});
saved!(SensorStateV5 for SensorState { lowpass: LowpassState, last_disturbed_t_s: Option<f64> });
saved!(HeldV5 for HeldSample { t_s: f64, m: Measurement });
saved!(JumpV5 for JumpCandidate { t_s: f64, count: u32 });
saved!(VehicleV5 for VehicleSnapshot {
    id: String,
    config: VehicleFilterConfig,
    filter: Option<FilterState>,
    seq: u64,
    generation: u64,
    last_t: Option<f64>,
    last_gyro: Option<GyroSample>,
    held: Vec<HeldSample>,
    newest: [Option<f64>; 3],
    first_t: Option<f64>,
    recent: [Vec<(f64, u64)>; 3],
    jump: Option<JumpCandidate>,
    gate: BTreeMap<String, GateCounts>,
    consecutive_gated: u32,
    consecutive_failures: u32,
    rollbacks: u64,
    reinits: BTreeMap<String, u64>,
    last_good: Option<Estimate>,
    sensor_state: BTreeMap<String, SensorState>,
    ahrs: Option<AhrsState>,
    gyro_feed: Option<Stream>,
    last_imu_estimate_t: Option<f64>,
});
saved!(CountersV5 for SavedCounters {
    received: u64,
    processed: u64,
    rejected: u64,
    rejected_by_code: BTreeMap<String, u64>,
});

/// The whole payload of a format-5 checkpoint.
#[derive(Serialize, Deserialize)]
pub struct CheckpointV5 {
    pub vehicle: VehicleV5,
    pub counters: CountersV5,
}
