//! Temporal filtering at the resolution of training frames: a hidden Markov model whose states
//! are (training frame, speed), so that a video is tracked *along* the training pass and its
//! zone follows from where on the pass it is.
//!
//! The zone-level HMM ([`crate::temporal`]) forgets where inside a zone the scope is: a frame
//! near a zone border is a coin flip there, whatever the frames before it said. Here the state
//! holds the training frame the test frame is nearest to (the definition of the ground-truth
//! zone, [`crate::ZoneTable::truth_zone`]) and the speed along the training pass, so the
//! filter carries the position within the zone from frame to frame, predicts the next one,
//! and crosses a border when the evidence has moved there.
//!
//! - **Speed** `v`, training frames per test frame, an integer in `−max_speed..=max_speed`
//!   (the scope may advance or withdraw, faster or slower than in the training pass): kept
//!   with probability `1 − speed_change`, else changed by ±1.
//! - **Position** `f`, a training frame: `f' = f + v' + Δ` with jitter
//!   `P(Δ) ∝ exp(−|Δ| / step_scale)`, `|Δ| ≤ max_step`; with probability `jump` the state
//!   goes anywhere instead (recovery after a run of wrong frames).
//! - **Emissions**: `p(test frame | f) ∝ exp(−(d_f − min d) / temperature)` with `d_f` the
//!   descriptor distance to training frame `f`
//!   ([`crate::DescriptorDatabase::frame_distances`]).
//! - **Zone**: the zone whose frames hold the most posterior mass (not the zone of the single
//!   most probable frame): this maximises the expected number of exact zones.
//!
//! [`TrackFilter`] is the causal forward filter (live use; `O(frames · speeds · max_step)`
//! per test frame, well under a millisecond for a few thousand training frames); [`smooth`]
//! runs forward–backward over a whole video (offline).

use serde::{Deserialize, Serialize};

/// Parameters of the frame-level HMM; probabilities are per test frame, positions and speeds
/// in training frames.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackConfig {
    /// Largest speed, training frames per test frame (`0`: a random walk without speed).
    pub max_speed: usize,
    /// Probability of the speed changing by one per test frame.
    pub speed_change: f64,
    /// Largest jitter of the position around `f + v`, training frames.
    pub max_step: usize,
    /// Scale of the jitter, training frames: `P(Δ) ∝ exp(−|Δ| / step_scale)`.
    pub step_scale: f64,
    /// Probability of a jump to any state.
    pub jump: f64,
    /// Emission temperature, descriptor-distance units: smaller trusts each frame more.
    pub temperature: f32,
}

impl Default for TrackConfig {
    /// Chosen on a second test pass of the simulator's `paper` colon (`paper2val/test`, not
    /// the pass the README reports on): temperature 0.1–0.8, speed change 0.005–0.1 and
    /// jitter 1 or 3 frames all give 91–93.5 % exact zones smoothed; these gave 87.0 %
    /// tracked, 92.8 % smoothed.
    fn default() -> Self {
        TrackConfig {
            max_speed: 3,
            speed_change: 0.02,
            max_step: 3,
            step_scale: 1.0,
            jump: 1e-3,
            temperature: 0.3,
        }
    }
}

impl TrackConfig {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`crate::NetError::Config`] naming the bad value.
    pub fn validate(&self) -> Result<(), crate::NetError> {
        let bad = |what: String| Err(crate::NetError::Config(format!("track: {what}")));
        if self.max_speed > 100 {
            return bad(format!("max_speed {} must be at most 100", self.max_speed));
        }
        if !(0.0..=1.0).contains(&self.speed_change) {
            return bad(format!(
                "speed_change {} must be in [0, 1]",
                self.speed_change
            ));
        }
        if self.max_step > 1000 {
            return bad(format!("max_step {} must be at most 1000", self.max_step));
        }
        if !(self.step_scale > 0.0 && self.step_scale.is_finite()) {
            return bad(format!("step_scale {} must be positive", self.step_scale));
        }
        if !(0.0..1.0).contains(&self.jump) {
            return bad(format!("jump {} must be in [0, 1)", self.jump));
        }
        if !(self.temperature > 0.0 && self.temperature.is_finite()) {
            return bad(format!("temperature {} must be positive", self.temperature));
        }
        Ok(())
    }

    /// The jitter weights `w[|Δ|]`, `Δ = −max_step..=max_step`, summing to `1 − jump`.
    fn kernel(&self) -> Vec<f64> {
        let w: Vec<f64> = (0..=self.max_step)
            .map(|d| (-(d as f64) / self.step_scale).exp())
            .collect();
        let total = w[0] + 2.0 * w[1..].iter().sum::<f64>();
        w.iter().map(|v| v * (1.0 - self.jump) / total).collect()
    }

    /// The speeds, training frames per test frame.
    fn speeds(&self) -> Vec<isize> {
        let m = self.max_speed as isize;
        (-m..=m).collect()
    }

    /// `P(speed b | speed a)` as a row-stochastic matrix over [`TrackConfig::speeds`].
    fn speed_matrix(&self) -> Vec<Vec<f64>> {
        let k = 2 * self.max_speed + 1;
        (0..k)
            .map(|a| {
                let mut row = vec![0.0; k];
                row[a] = 1.0 - self.speed_change;
                let neighbours: Vec<usize> = [a.checked_sub(1), (a + 1 < k).then_some(a + 1)]
                    .into_iter()
                    .flatten()
                    .collect();
                if neighbours.is_empty() {
                    row[a] = 1.0;
                }
                for &b in &neighbours {
                    row[b] = self.speed_change / neighbours.len() as f64;
                }
                row
            })
            .collect()
    }
}

/// Where the track filter puts one test frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackEstimate {
    /// The zone holding the most posterior mass.
    pub zone: usize,
    /// Its posterior probability.
    pub zone_probability: f64,
    /// The most probable training frame.
    pub frame: usize,
    /// The expected speed, training frames per test frame.
    pub speed: f64,
}

/// `out[j] = Σ_i w[|j − shift − i|] · src[i]`: the jitter kernel centred `shift` frames on.
/// With `−shift` it is the transpose (the backward message of the same move).
fn shift_convolve(src: &[f64], kernel: &[f64], shift: isize, out: &mut [f64]) {
    let n = src.len() as isize;
    let b = kernel.len() as isize - 1;
    for (j, o) in out.iter_mut().enumerate() {
        let centre = j as isize - shift;
        let lo = (centre - b).max(0);
        let hi = (centre + b).min(n - 1);
        let mut s = 0.0;
        for i in lo..=hi {
            s += kernel[(centre - i).unsigned_abs()] * src[i as usize];
        }
        *o = s;
    }
}

/// Emission likelihoods `exp(−(d_f − min d) / T)`; frames without a finite distance get 0.
/// All frames get 1 when no distance is finite (the frame carries no evidence).
fn emission(distances: &[f32], temperature: f32) -> Vec<f64> {
    let min = distances
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f32::INFINITY, f32::min);
    if !min.is_finite() {
        return vec![1.0; distances.len()];
    }
    distances
        .iter()
        .map(|&d| {
            if d.is_finite() {
                (-f64::from((d - min) / temperature)).exp()
            } else {
                0.0
            }
        })
        .collect()
}

fn normalise(v: &mut [f64]) {
    let s: f64 = v.iter().sum();
    if s > 0.0 && s.is_finite() {
        v.iter_mut().for_each(|x| *x /= s);
    } else {
        let u = 1.0 / v.len().max(1) as f64;
        v.fill(u);
    }
}

/// The transition model over states `(speed index, frame)`, stored speed-major: state
/// `k · n + f`.
#[derive(Debug, Clone)]
struct Model {
    cfg: TrackConfig,
    n: usize,
    speeds: Vec<isize>,
    speed_p: Vec<Vec<f64>>,
    kernel: Vec<f64>,
}

impl Model {
    fn new(n: usize, cfg: TrackConfig) -> Self {
        Model {
            cfg,
            n,
            speeds: cfg.speeds(),
            speed_p: cfg.speed_matrix(),
            kernel: cfg.kernel(),
        }
    }

    fn states(&self) -> usize {
        self.n * self.speeds.len()
    }

    /// One step forward: `out(b, f') = Σ_a P(b|a) Σ_f K(f' − f − v_b) p(a, f) + jump · Σp / S`.
    fn predict(&self, p: &[f64], out: &mut [f64]) {
        let n = self.n;
        let k = self.speeds.len();
        let spread = self.cfg.jump * p.iter().sum::<f64>() / self.states() as f64;
        let mut mixed = vec![0.0; n];
        for b in 0..k {
            mixed.fill(0.0);
            for a in 0..k {
                let w = self.speed_p[a][b];
                if w > 0.0 {
                    for (m, v) in mixed.iter_mut().zip(&p[a * n..(a + 1) * n]) {
                        *m += w * v;
                    }
                }
            }
            let dst = &mut out[b * n..(b + 1) * n];
            shift_convolve(&mixed, &self.kernel, self.speeds[b], dst);
            dst.iter_mut().for_each(|v| *v += spread);
        }
    }

    /// One step backward (the transpose of [`Model::predict`]):
    /// `out(a, f) = Σ_b P(b|a) Σ_f' K(f' − f − v_b) q(b, f') + jump · Σq / S`.
    fn back(&self, q: &[f64], out: &mut [f64]) {
        let n = self.n;
        let k = self.speeds.len();
        let spread = self.cfg.jump * q.iter().sum::<f64>() / self.states() as f64;
        let mut moved = vec![0.0; k * n];
        for b in 0..k {
            shift_convolve(
                &q[b * n..(b + 1) * n],
                &self.kernel,
                -self.speeds[b],
                &mut moved[b * n..(b + 1) * n],
            );
        }
        for a in 0..k {
            let dst = &mut out[a * n..(a + 1) * n];
            dst.fill(spread);
            for b in 0..k {
                let w = self.speed_p[a][b];
                if w > 0.0 {
                    for (o, v) in dst.iter_mut().zip(&moved[b * n..(b + 1) * n]) {
                        *o += w * v;
                    }
                }
            }
        }
    }

    /// Multiplies every speed's block by the frame emissions.
    fn weigh(&self, p: &mut [f64], e: &[f64]) {
        for block in p.chunks_exact_mut(self.n) {
            for (v, w) in block.iter_mut().zip(e) {
                *v *= w;
            }
        }
    }

    /// The estimate from a posterior over states.
    fn estimate(&self, post: &[f64], zone_of_frame: &[usize], zones: usize) -> TrackEstimate {
        let n = self.n;
        let mut frames = vec![0.0; n];
        let mut speed = 0.0;
        for (k, block) in post.chunks_exact(n).enumerate() {
            for (f, v) in frames.iter_mut().zip(block) {
                *f += v;
            }
            speed += self.speeds[k] as f64 * block.iter().sum::<f64>();
        }
        let mut mass = vec![0.0; zones.max(1)];
        for (p, &z) in frames.iter().zip(zone_of_frame) {
            if let Some(m) = mass.get_mut(z) {
                *m += p;
            }
        }
        let (zone, &zone_probability) = mass
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &0.0));
        let frame = frames
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(i, _)| i);
        TrackEstimate {
            zone,
            zone_probability,
            frame,
            speed,
        }
    }
}

/// Causal forward filter over (training frame, speed) (see the module documentation).
#[derive(Debug, Clone)]
pub struct TrackFilter {
    model: Model,
    zone_of_frame: Vec<usize>,
    zones: usize,
    belief: Vec<f64>,
    started: bool,
}

impl TrackFilter {
    /// A filter over the training frames whose zones are `zone_of_frame`
    /// ([`crate::ZoneTable::zone_of_frame`]), starting from a uniform belief.
    ///
    /// # Errors
    /// [`crate::NetError::Config`] for bad parameters or no training frames.
    pub fn new(zone_of_frame: Vec<usize>, cfg: TrackConfig) -> Result<Self, crate::NetError> {
        cfg.validate()?;
        if zone_of_frame.is_empty() {
            return Err(crate::NetError::Config(
                "track: the model has no training frames".into(),
            ));
        }
        let model = Model::new(zone_of_frame.len(), cfg);
        let s = model.states();
        let zones = zone_of_frame.iter().max().map_or(1, |z| z + 1);
        Ok(TrackFilter {
            model,
            zone_of_frame,
            zones,
            belief: vec![1.0 / s as f64; s],
            started: false,
        })
    }

    /// Forgets the past (a new video).
    pub fn reset(&mut self) {
        let s = self.belief.len();
        self.belief.fill(1.0 / s as f64);
        self.started = false;
    }

    /// The current posterior over training frames (summed over speeds).
    pub fn frame_belief(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.model.n];
        for block in self.belief.chunks_exact(self.model.n) {
            for (o, v) in out.iter_mut().zip(block) {
                *o += v;
            }
        }
        out
    }

    /// Puts the position at training frame `frame` (e.g. the training frame nearest to a pose
    /// registered geometrically) with probability `1 − ε`, `ε = 0.05` spread evenly; the
    /// speed belief is kept. A frame out of range is ignored.
    pub fn anchor(&mut self, frame: usize) {
        let n = self.model.n;
        if frame >= n {
            return;
        }
        const EPS: f64 = 0.05;
        let s = self.belief.len() as f64;
        let speed_mass: Vec<f64> = self
            .belief
            .chunks_exact(n)
            .map(|b| b.iter().sum::<f64>())
            .collect();
        for (k, block) in self.belief.chunks_exact_mut(n).enumerate() {
            block.fill(EPS / s);
            block[frame] += (1.0 - EPS) * speed_mass[k];
        }
        normalise(&mut self.belief);
        self.started = true;
    }

    /// Folds in one test frame's distances to every training frame and returns the estimate.
    ///
    /// # Errors
    /// [`crate::NetError::Config`] when `distances` does not have one entry per training frame.
    pub fn update(&mut self, distances: &[f32]) -> Result<TrackEstimate, crate::NetError> {
        check_len(distances, self.model.n)?;
        self.step(&emission(distances, self.model.cfg.temperature));
        Ok(self
            .model
            .estimate(&self.belief, &self.zone_of_frame, self.zones))
    }

    fn step(&mut self, e: &[f64]) {
        if self.started {
            let mut post = vec![0.0; self.belief.len()];
            self.model.predict(&self.belief, &mut post);
            self.belief = post;
        }
        self.model.weigh(&mut self.belief, e);
        normalise(&mut self.belief);
        self.started = true;
    }
}

fn check_len(distances: &[f32], n: usize) -> Result<(), crate::NetError> {
    if distances.len() == n {
        Ok(())
    } else {
        Err(crate::NetError::Config(format!(
            "track: {} distances for a model of {n} training frames",
            distances.len()
        )))
    }
}

/// Fixed-lag smoothing: the estimate of test frame `t` given frames up to `t + lag` (the last
/// `lag` frames of the video get what follows them). `lag = 0` is the forward filter; a lag
/// as long as the video is [`smooth`]. Live, this is the estimate `lag` frames late.
///
/// Work: `lag` backward steps per frame; memory `lag + 1` forward messages.
///
/// # Errors
/// As [`TrackFilter::new`] and [`TrackFilter::update`].
pub fn fixed_lag(
    distances: &[Vec<f32>],
    zone_of_frame: &[usize],
    cfg: &TrackConfig,
    lag: usize,
) -> Result<Vec<TrackEstimate>, crate::NetError> {
    let n = zone_of_frame.len();
    for d in distances {
        check_len(d, n)?;
    }
    let mut filter = TrackFilter::new(zone_of_frame.to_vec(), *cfg)?;
    let t_len = distances.len();
    let emit = |t: usize| emission(&distances[t], cfg.temperature);
    let mut alphas: std::collections::VecDeque<Vec<f64>> =
        std::collections::VecDeque::with_capacity(lag + 1);
    let mut out = Vec::with_capacity(t_len);
    let model = filter.model.clone();
    let zones = filter.zones;
    let s = model.states();
    // The estimate of frame `target` from the forward message kept for it and the frames
    // after it up to `last`.
    let estimate_at = |alpha: &[f64], target: usize, last: usize| {
        let mut beta = vec![1.0 / s as f64; s];
        let mut weighted = vec![0.0; s];
        for t in (target..last).rev() {
            weighted.copy_from_slice(&beta);
            model.weigh(&mut weighted, &emit(t + 1));
            model.back(&weighted, &mut beta);
            normalise(&mut beta);
        }
        let mut post: Vec<f64> = alpha.iter().zip(&beta).map(|(a, b)| a * b).collect();
        normalise(&mut post);
        model.estimate(&post, zone_of_frame, zones)
    };
    for t in 0..t_len {
        filter.step(&emit(t));
        alphas.push_back(filter.belief.clone());
        if alphas.len() > lag {
            let alpha = alphas.pop_front().unwrap_or_default();
            out.push(estimate_at(&alpha, t - lag, t));
        }
    }
    // The last frames: what follows them is all there is.
    let first = out.len();
    for (k, alpha) in alphas.iter().enumerate() {
        out.push(estimate_at(alpha, first + k, t_len - 1));
    }
    Ok(out)
}

/// Offline forward–backward over a whole video: the estimate of every test frame given all
/// of them. `distances[t]` holds test frame `t`'s distance to every training frame.
///
/// Memory: the forward messages are kept only every `√T` frames and recomputed block by block
/// during the backward pass (twice the forward work, `O(√T · states)` memory).
///
/// # Errors
/// As [`TrackFilter::new`] and [`TrackFilter::update`].
pub fn smooth(
    distances: &[Vec<f32>],
    zone_of_frame: &[usize],
    cfg: &TrackConfig,
) -> Result<Vec<TrackEstimate>, crate::NetError> {
    let t_len = distances.len();
    let n = zone_of_frame.len();
    for d in distances {
        check_len(d, n)?;
    }
    let mut filter = TrackFilter::new(zone_of_frame.to_vec(), *cfg)?;
    if t_len == 0 {
        return Ok(Vec::new());
    }
    let block = (t_len as f64).sqrt().ceil() as usize;
    let emit = |t: usize| emission(&distances[t], cfg.temperature);
    // Forward pass, keeping the filter state at the start of every block.
    let mut checkpoints = Vec::with_capacity(t_len.div_ceil(block));
    for t in 0..t_len {
        if t % block == 0 {
            checkpoints.push(filter.clone());
        }
        filter.step(&emit(t));
    }
    let model = filter.model.clone();
    let s = model.states();
    let mut out = vec![
        TrackEstimate {
            zone: 0,
            zone_probability: 0.0,
            frame: 0,
            speed: 0.0,
        };
        t_len
    ];
    let mut beta = vec![1.0 / s as f64; s];
    let mut weighted = vec![0.0; s];
    let mut post = vec![0.0; s];
    let mut next_emission: Option<Vec<f64>> = None;
    for (c, start) in checkpoints.into_iter().enumerate().rev() {
        let first = c * block;
        let last = (first + block).min(t_len);
        let mut f = start;
        let mut alphas = Vec::with_capacity(last - first);
        for t in first..last {
            f.step(&emit(t));
            alphas.push(f.belief.clone());
        }
        for t in (first..last).rev() {
            if let Some(e) = &next_emission {
                // β_t = Pᵀ (e_{t+1} ⊙ β_{t+1}).
                weighted.copy_from_slice(&beta);
                model.weigh(&mut weighted, e);
                model.back(&weighted, &mut beta);
                normalise(&mut beta);
            }
            for ((p, a), b) in post.iter_mut().zip(&alphas[t - first]).zip(&beta) {
                *p = a * b;
            }
            normalise(&mut post);
            out[t] = model.estimate(&post, zone_of_frame, filter.zones);
            next_emission = Some(emit(t));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distances of a test frame that looks like training frame `f` (0.1 there, growing
    /// with the distance along the pass, capped at 1).
    fn looks_like(f: usize, n: usize) -> Vec<f32> {
        (0..n)
            .map(|i| (0.1 + 0.02 * i.abs_diff(f) as f32).min(1.0))
            .collect()
    }

    fn zones_of(n: usize, per_zone: usize) -> Vec<usize> {
        (0..n).map(|i| i / per_zone).collect()
    }

    #[test]
    fn speed_rows_sum_to_one() {
        for m in [0, 1, 3] {
            let cfg = TrackConfig {
                max_speed: m,
                ..TrackConfig::default()
            };
            for row in cfg.speed_matrix() {
                assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn backward_step_is_the_transpose_of_the_forward_step() {
        // <P x, y> = <x, Pᵀ y> for random x, y: checks `back` against `predict`.
        let n = 30;
        let m = Model::new(n, TrackConfig::default());
        let s = m.states();
        let x: Vec<f64> = (0..s).map(|i| ((i * 7919) % 97) as f64 / 97.0).collect();
        let y: Vec<f64> = (0..s).map(|i| ((i * 104729) % 89) as f64 / 89.0).collect();
        let (mut px, mut pty) = (vec![0.0; s], vec![0.0; s]);
        m.predict(&x, &mut px);
        m.back(&y, &mut pty);
        let lhs: f64 = px.iter().zip(&y).map(|(a, b)| a * b).sum();
        let rhs: f64 = x.iter().zip(&pty).map(|(a, b)| a * b).sum();
        assert!((lhs - rhs).abs() < 1e-9 * lhs.abs(), "{lhs} vs {rhs}");
    }

    #[test]
    fn kernel_sums_to_one_minus_jump() {
        let cfg = TrackConfig::default();
        let k = cfg.kernel();
        let total = k[0] + 2.0 * k[1..].iter().sum::<f64>();
        assert!((total - (1.0 - cfg.jump)).abs() < 1e-12);
        assert!(k.windows(2).all(|w| w[0] > w[1]), "weights fall with |Δ|");
    }

    #[test]
    fn prediction_keeps_mass_and_moves_at_the_speed() {
        let cfg = TrackConfig {
            speed_change: 0.0,
            ..TrackConfig::default()
        };
        let n = 100;
        let m = Model::new(n, cfg);
        let mut p = vec![0.0; m.states()];
        // Speed +2 (index max_speed + 2), frame 50.
        p[(cfg.max_speed + 2) * n + 50] = 1.0;
        let mut out = vec![0.0; m.states()];
        m.predict(&p, &mut out);
        assert!((out.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let block = &out[(cfg.max_speed + 2) * n..(cfg.max_speed + 3) * n];
        assert!(block[52] > block[53] && block[53] > block[54] && block[51] == block[53]);
    }

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn filter_follows_a_pass_and_ignores_a_wrong_frame() {
        let n = 200;
        let zof = zones_of(n, 20);
        let mut f = TrackFilter::new(zof.clone(), TrackConfig::default()).unwrap();
        for t in 0..150 {
            // Frame 100 looks like frame 20 (another place); the filter must not jump there.
            let seen = if t == 100 { 20 } else { t };
            let e = f.update(&looks_like(seen, n)).unwrap();
            if t > 5 {
                assert!(
                    e.frame.abs_diff(t) <= 2,
                    "frame {t}: tracked at {}",
                    e.frame
                );
                assert_eq!(e.zone, zof[t], "frame {t}");
            }
        }
    }

    #[test]
    fn border_frames_go_to_the_zone_of_their_position() {
        // A test pass at the training pass's speed, whose frames near the border between
        // zones 1 and 2 (frames 38..42) look alike: the track knows which side it is on.
        let n = 100;
        let zof = zones_of(n, 20);
        let dist: Vec<Vec<f32>> = (0..n)
            .map(|t| {
                let mut d = looks_like(t, n);
                if (38..42).contains(&t) {
                    for v in &mut d[36..44] {
                        *v = 0.1;
                    }
                }
                d
            })
            .collect();
        let est = smooth(&dist, &zof, &TrackConfig::default()).unwrap();
        for t in 3..n - 3 {
            assert_eq!(est[t].zone, zof[t], "frame {t}");
        }
    }

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn smoothing_fixes_frames_the_forward_filter_gets_wrong() {
        // Three frames after t = 50 carry no evidence of the scope having moved on: forward
        // filtering cannot know, smoothing can (the frames after them say it moved).
        let n = 120;
        let zof = zones_of(n, 10);
        let dist: Vec<Vec<f32>> = (0..100)
            .map(|t| {
                if (51..54).contains(&t) {
                    vec![0.5; n]
                } else {
                    looks_like(t, n)
                }
            })
            .collect();
        let est = smooth(&dist, &zof, &TrackConfig::default()).unwrap();
        for t in 45..60 {
            assert!(est[t].frame.abs_diff(t) <= 1, "frame {t}: {}", est[t].frame);
        }
    }

    /// Forward–backward with every forward message kept (no checkpoints): the reference for
    /// [`smooth`].
    fn smooth_reference(d: &[Vec<f32>], zof: &[usize], cfg: &TrackConfig) -> Vec<TrackEstimate> {
        let mut f = TrackFilter::new(zof.to_vec(), *cfg).unwrap();
        let alphas: Vec<Vec<f64>> = d
            .iter()
            .map(|x| {
                f.update(x).unwrap();
                f.belief.clone()
            })
            .collect();
        let m = f.model.clone();
        let s = m.states();
        let mut beta = vec![1.0; s];
        let mut out = Vec::new();
        for t in (0..d.len()).rev() {
            if t + 1 < d.len() {
                let mut w = beta.clone();
                m.weigh(&mut w, &emission(&d[t + 1], cfg.temperature));
                m.back(&w, &mut beta);
                normalise(&mut beta);
            }
            let mut post: Vec<f64> = alphas[t].iter().zip(&beta).map(|(a, b)| a * b).collect();
            normalise(&mut post);
            out.push(m.estimate(&post, zof, f.zones));
        }
        out.reverse();
        out
    }

    #[test]
    fn checkpointed_smoothing_equals_the_plain_forward_backward() {
        let n = 40;
        let zof = zones_of(n, 8);
        // A noisy pass: the true frame advances by one, every fifth frame looks elsewhere.
        let d: Vec<Vec<f32>> = (0..37)
            .map(|t| looks_like(if t % 5 == 3 { (t * 7) % n } else { t }, n))
            .collect();
        let cfg = TrackConfig::default();
        let fast = smooth(&d, &zof, &cfg).unwrap();
        let slow = smooth_reference(&d, &zof, &cfg);
        for (t, (a, b)) in fast.iter().zip(&slow).enumerate() {
            assert_eq!((a.zone, a.frame), (b.zone, b.frame), "frame {t}");
            assert!(
                (a.zone_probability - b.zone_probability).abs() < 1e-9,
                "frame {t}"
            );
        }
        // The last frame has no future: smoothing equals filtering there.
        let mut f = TrackFilter::new(zof, cfg).unwrap();
        let last = d.iter().map(|x| f.update(x).unwrap()).last().unwrap();
        assert_eq!((last.zone, last.frame), (fast[36].zone, fast[36].frame));
    }

    #[test]
    fn fixed_lag_spans_filtering_and_smoothing() {
        let n = 40;
        let zof = zones_of(n, 8);
        let d: Vec<Vec<f32>> = (0..30)
            .map(|t| looks_like(if t % 5 == 3 { (t * 7) % n } else { t }, n))
            .collect();
        let cfg = TrackConfig::default();
        let key = |e: &TrackEstimate| (e.zone, e.frame);
        let mut f = TrackFilter::new(zof.clone(), cfg).unwrap();
        let forward: Vec<_> = d.iter().map(|x| key(&f.update(x).unwrap())).collect();
        let lag0: Vec<_> = fixed_lag(&d, &zof, &cfg, 0)
            .unwrap()
            .iter()
            .map(key)
            .collect();
        assert_eq!(lag0, forward);
        let full: Vec<_> = smooth(&d, &zof, &cfg).unwrap().iter().map(key).collect();
        let long: Vec<_> = fixed_lag(&d, &zof, &cfg, 30)
            .unwrap()
            .iter()
            .map(key)
            .collect();
        assert_eq!(long, full);
        assert_eq!(fixed_lag(&d, &zof, &cfg, 5).unwrap().len(), d.len());
    }

    #[test]
    fn wrong_lengths_and_bad_parameters_are_errors() {
        let mut f = TrackFilter::new(zones_of(10, 5), TrackConfig::default()).unwrap();
        assert!(f.update(&[0.1; 9]).is_err());
        assert!(smooth(&[vec![0.1; 9]], &zones_of(10, 5), &TrackConfig::default()).is_err());
        assert!(TrackFilter::new(Vec::new(), TrackConfig::default()).is_err());
        let bad = TrackConfig {
            jump: 1.0,
            ..TrackConfig::default()
        };
        assert!(bad.validate().is_err());
        let bad = TrackConfig {
            temperature: 0.0,
            ..TrackConfig::default()
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn a_frame_without_evidence_keeps_the_belief_moving() {
        let n = 50;
        let mut f = TrackFilter::new(zones_of(n, 10), TrackConfig::default()).unwrap();
        f.anchor(25);
        let e = f.update(&[f32::INFINITY; 50]).unwrap();
        // Speeds are still unknown (uniform in ±3): the position spreads by at most 3 + 3.
        assert_eq!(e.zone, 2);
        assert!(e.zone_probability > 0.8, "{}", e.zone_probability);
        assert!(e.frame.abs_diff(25) <= 3);
    }
}
