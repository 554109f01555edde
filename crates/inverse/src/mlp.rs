//! A small multilayer perceptron (tanh hidden layers, linear output, mean-squared-error loss, Adam,
//! early stopping on a validation set).
//!
//! Why hand-written: the network of paper 003 has 9 inputs, two hidden layers of 30 and 6 outputs
//! (1 326 parameters) trained on ~2 000 samples. The Rust deep-learning crates (burn, candle, tch) bring
//! tensor back-ends that cost minutes of build time and hundreds of dependencies on a 2-core CI for
//! what is here ~150 lines of plain loops; the lighter ones (e.g. linfa) have no MLP regressor. The
//! backward pass is checked against central finite differences (test `gradient_matches_finite_differences`).

use rand::Rng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;

/// A fully connected network; the parameters are one flat vector, layer by layer, weights (row-major,
/// `out × in`) then biases.
#[derive(Debug, Clone, PartialEq)]
pub struct Mlp {
    sizes: Vec<usize>,
    params: Vec<f64>,
}

/// Training settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainOptions {
    /// Adam step size.
    pub learning_rate: f64,
    /// Mini-batch size.
    pub batch: usize,
    /// Upper bound on epochs.
    pub max_epochs: usize,
    /// Stop after this many epochs without a better validation loss (then restore the best network).
    pub patience: usize,
    /// Seed of the initialisation and the batch shuffling.
    pub seed: u64,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            learning_rate: 2e-3,
            batch: 32,
            max_epochs: 2000,
            patience: 100,
            seed: 1,
        }
    }
}

/// How training went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainReport {
    /// Epochs run.
    pub epochs: usize,
    /// Epoch of the kept (best-validation) network.
    pub best_epoch: usize,
    /// MSE on the training set of the kept network (standardised outputs).
    pub train_mse: f64,
    /// MSE on the validation set of the kept network.
    pub val_mse: f64,
}

impl Mlp {
    /// Network with layer sizes `sizes` (input, hidden…, output), Glorot-uniform weights, zero biases.
    pub fn new(sizes: &[usize], seed: u64) -> Mlp {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut params = Vec::new();
        for w in sizes.windows(2) {
            let limit = (6.0 / (w[0] + w[1]) as f64).sqrt();
            params.extend((0..w[0] * w[1]).map(|_| rng.random_range(-limit..limit)));
            params.extend(std::iter::repeat_n(0.0, w[1]));
        }
        Mlp {
            sizes: sizes.to_vec(),
            params,
        }
    }

    /// Layer sizes.
    pub fn sizes(&self) -> &[usize] {
        &self.sizes
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.params.len()
    }

    /// Activations of every layer for input `x` (the last is the output).
    fn activations(&self, x: &[f64]) -> Vec<Vec<f64>> {
        let mut acts = vec![x.to_vec()];
        let mut off = 0;
        let n_layers = self.sizes.len() - 1;
        for l in 0..n_layers {
            let (n_in, n_out) = (self.sizes[l], self.sizes[l + 1]);
            let w = &self.params[off..off + n_in * n_out];
            let b = &self.params[off + n_in * n_out..off + n_in * n_out + n_out];
            let a = &acts[l];
            let z: Vec<f64> = (0..n_out)
                .map(|o| {
                    let row = &w[o * n_in..(o + 1) * n_in];
                    b[o] + row.iter().zip(a).map(|(wi, ai)| wi * ai).sum::<f64>()
                })
                .collect();
            let z = if l + 1 < n_layers {
                z.into_iter().map(f64::tanh).collect()
            } else {
                z
            };
            acts.push(z);
            off += n_in * n_out + n_out;
        }
        acts
    }

    /// Output for input `x`.
    pub fn predict(&self, x: &[f64]) -> Vec<f64> {
        self.activations(x).pop().unwrap_or_default()
    }

    /// Mean squared error over samples and outputs.
    pub fn mse(&self, xs: &[Vec<f64>], ys: &[Vec<f64>]) -> f64 {
        let mut s = 0.0;
        let mut n = 0usize;
        for (x, y) in xs.iter().zip(ys) {
            for (p, t) in self.predict(x).iter().zip(y) {
                s += (p - t).powi(2);
                n += 1;
            }
        }
        if n == 0 { f64::NAN } else { s / n as f64 }
    }

    /// Gradient of [`Mlp::mse`] over the samples `idx` of `xs`, `ys`, added into `grad` (zeroed first).
    fn gradient(&self, xs: &[Vec<f64>], ys: &[Vec<f64>], idx: &[usize], grad: &mut [f64]) {
        grad.iter_mut().for_each(|g| *g = 0.0);
        let n_layers = self.sizes.len() - 1;
        let n_out = self.sizes[n_layers];
        let scale = 2.0 / (idx.len() * n_out) as f64;
        let mut offsets = Vec::with_capacity(n_layers);
        let mut off = 0;
        for l in 0..n_layers {
            offsets.push(off);
            off += self.sizes[l] * self.sizes[l + 1] + self.sizes[l + 1];
        }
        for &k in idx {
            let acts = self.activations(&xs[k]);
            // δ of the output layer (linear): ∂L/∂z = scale (ŷ − y).
            let mut delta: Vec<f64> = acts[n_layers]
                .iter()
                .zip(&ys[k])
                .map(|(p, t)| scale * (p - t))
                .collect();
            for l in (0..n_layers).rev() {
                let (n_in, n_o) = (self.sizes[l], self.sizes[l + 1]);
                let off = offsets[l];
                let a = &acts[l];
                for o in 0..n_o {
                    let row = &mut grad[off + o * n_in..off + (o + 1) * n_in];
                    for (g, ai) in row.iter_mut().zip(a) {
                        *g += delta[o] * ai;
                    }
                    grad[off + n_in * n_o + o] += delta[o];
                }
                if l > 0 {
                    let w = &self.params[off..off + n_in * n_o];
                    delta = (0..n_in)
                        .map(|i| {
                            let back: f64 = (0..n_o).map(|o| w[o * n_in + i] * delta[o]).sum();
                            back * (1.0 - a[i] * a[i]) // tanh' = 1 − tanh²
                        })
                        .collect();
                }
            }
        }
    }

    /// Trains on (`xs`, `ys`) with Adam, keeping the network of the best validation MSE.
    pub fn train(
        &mut self,
        xs: &[Vec<f64>],
        ys: &[Vec<f64>],
        val_x: &[Vec<f64>],
        val_y: &[Vec<f64>],
        opts: &TrainOptions,
    ) -> TrainReport {
        let (b1, b2, eps): (f64, f64, f64) = (0.9, 0.999, 1e-8);
        let np = self.params.len();
        let (mut m, mut v, mut g) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed.wrapping_add(0x9e37_79b9));
        let mut order: Vec<usize> = (0..xs.len()).collect();
        let mut best = (self.mse(val_x, val_y), self.params.clone(), 0usize);
        let mut step = 0i32;
        let mut epochs = 0;
        for epoch in 1..=opts.max_epochs {
            epochs = epoch;
            order.shuffle(&mut rng);
            for batch in order.chunks(opts.batch.max(1)) {
                self.gradient(xs, ys, batch, &mut g);
                step += 1;
                let (c1, c2) = (1.0 - b1.powi(step), 1.0 - b2.powi(step));
                for i in 0..np {
                    m[i] = b1 * m[i] + (1.0 - b1) * g[i];
                    v[i] = b2 * v[i] + (1.0 - b2) * g[i] * g[i];
                    self.params[i] -= opts.learning_rate * (m[i] / c1) / ((v[i] / c2).sqrt() + eps);
                }
            }
            let val = self.mse(val_x, val_y);
            if val < best.0 {
                best = (val, self.params.clone(), epoch);
            } else if epoch - best.2 >= opts.patience {
                break;
            }
        }
        self.params = best.1;
        TrainReport {
            epochs,
            best_epoch: best.2,
            train_mse: self.mse(xs, ys),
            val_mse: best.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_matches_finite_differences() {
        let net = Mlp::new(&[3, 5, 4, 2], 7);
        let xs: Vec<Vec<f64>> = (0..6)
            .map(|k| (0..3).map(|j| ((k * 3 + j) as f64 * 0.37).sin()).collect())
            .collect();
        let ys: Vec<Vec<f64>> = (0..6)
            .map(|k| vec![(k as f64 * 0.5).cos(), k as f64 * 0.1 - 0.2])
            .collect();
        let idx: Vec<usize> = (0..6).collect();
        let mut g = vec![0.0; net.n_params()];
        net.gradient(&xs, &ys, &idx, &mut g);
        let h = 1e-6;
        for (p, gp) in g.iter().enumerate() {
            let (mut plus, mut minus) = (net.clone(), net.clone());
            plus.params[p] += h;
            minus.params[p] -= h;
            let fd = (plus.mse(&xs, &ys) - minus.mse(&xs, &ys)) / (2.0 * h);
            assert!(
                (fd - gp).abs() <= 1e-7 * (1.0 + fd.abs()),
                "parameter {p}: backprop {gp} vs finite difference {fd}"
            );
        }
    }

    #[test]
    fn learns_a_smooth_map_and_stops_early() {
        // y = (sin x0, x0 x1): a small network must fit it far better than the variance (≈ 0.3–0.5).
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut sample = |n: usize| {
            let xs: Vec<Vec<f64>> = (0..n)
                .map(|_| vec![rng.random_range(-2.0..2.0), rng.random_range(-1.0..1.0)])
                .collect();
            let ys = xs
                .iter()
                .map(|x| vec![x[0].sin(), x[0] * x[1]])
                .collect::<Vec<_>>();
            (xs, ys)
        };
        let (xt, yt) = sample(400);
        let (xv, yv) = sample(100);
        let mut net = Mlp::new(&[2, 16, 16, 2], 1);
        let before = net.mse(&xv, &yv);
        let opts = TrainOptions {
            max_epochs: 400,
            patience: 20,
            ..TrainOptions::default()
        };
        let rep = net.train(&xt, &yt, &xv, &yv, &opts);
        assert!(
            rep.val_mse < 0.01,
            "validation MSE {} (before {before})",
            rep.val_mse
        );
        assert!(rep.best_epoch <= rep.epochs);
        assert_eq!(
            net.mse(&xv, &yv),
            rep.val_mse,
            "the best network is restored"
        );
    }
}
