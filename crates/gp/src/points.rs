//! A set of input points, row-major: point i is `data[i*dims..(i+1)*dims]`.

use serde::{Deserialize, Serialize};

use crate::error::GpError;

/// n points of dimension `dims`, finite, stored row-major.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Points {
    dims: usize,
    data: Vec<f64>,
}

impl Points {
    /// Points from a row-major buffer; every value must be finite.
    pub fn new(dims: usize, data: Vec<f64>) -> Result<Points, GpError> {
        if dims == 0 {
            return Err(GpError::Empty { points: 0, dims });
        }
        if !data.len().is_multiple_of(dims) {
            return Err(GpError::LengthMismatch {
                what: "point buffer (a multiple of the dimension)",
                expected: data.len().div_ceil(dims) * dims,
                got: data.len(),
            });
        }
        if let Some((index, &value)) = data.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(GpError::NonFinite {
                what: "input points",
                index: index / dims,
                value,
            });
        }
        Ok(Points { dims, data })
    }

    /// Points from rows; every row must have the same length.
    pub fn from_rows(rows: &[Vec<f64>]) -> Result<Points, GpError> {
        let dims = rows.first().map_or(0, Vec::len);
        let mut data = Vec::with_capacity(rows.len() * dims);
        for r in rows {
            if r.len() != dims {
                return Err(GpError::LengthMismatch {
                    what: "point dimension",
                    expected: dims,
                    got: r.len(),
                });
            }
            data.extend_from_slice(r);
        }
        Points::new(dims, data)
    }

    pub fn dims(&self) -> usize {
        self.dims
    }

    pub fn len(&self) -> usize {
        self.data.len() / self.dims
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    pub fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.dims..(i + 1) * self.dims]
    }

    /// The rows at `indices`, in that order.
    pub fn select(&self, indices: &[usize]) -> Points {
        let mut data = Vec::with_capacity(indices.len() * self.dims);
        for &i in indices {
            data.extend_from_slice(self.row(i));
        }
        Points {
            dims: self.dims,
            data,
        }
    }

    /// Rows as vectors (for files).
    pub fn to_rows(&self) -> Vec<Vec<f64>> {
        (0..self.len()).map(|i| self.row(i).to_vec()).collect()
    }
}
