//! Shared-token authentication: every RPC must carry `authorization: Bearer <token>`. The
//! comparison takes the same time whatever the mismatch, so the token cannot be guessed byte
//! by byte.

use tonic::{Request, Status};

/// A tonic interceptor that checks the bearer token (or lets everything through if `None`).
#[derive(Clone)]
pub struct BearerAuth {
    expected: Option<Vec<u8>>,
}

impl BearerAuth {
    pub fn new(token: Option<&str>) -> Self {
        BearerAuth { expected: token.map(|t| format!("Bearer {t}").into_bytes()) }
    }

    pub fn check<T>(&self, req: Request<T>) -> Result<Request<T>, Status> {
        let Some(expected) = &self.expected else { return Ok(req) };
        let got = req.metadata().get("authorization").map(|v| v.as_bytes()).unwrap_or_default();
        let same = got.len() == expected.len() && got.iter().zip(expected).fold(0u8, |acc, (a, b)| acc | (a ^ b)) == 0;
        if same { Ok(req) } else { Err(Status::unauthenticated("missing or wrong bearer token")) }
    }
}

/// Adds the bearer token to outgoing requests (clients and workers).
#[derive(Clone)]
pub struct AttachToken {
    header: Option<tonic::metadata::MetadataValue<tonic::metadata::Ascii>>,
}

impl AttachToken {
    /// # Errors
    /// If the token is not valid header text.
    pub fn new(token: Option<&str>) -> Result<Self, String> {
        let header = token
            .map(|t| format!("Bearer {t}").parse().map_err(|_| "the token must be printable ASCII".to_owned()))
            .transpose()?;
        Ok(AttachToken { header })
    }
}

impl tonic::service::Interceptor for AttachToken {
    fn call(&mut self, mut req: Request<()>) -> Result<Request<()>, Status> {
        if let Some(h) = &self.header {
            req.metadata_mut().insert("authorization", h.clone());
        }
        Ok(req)
    }
}
