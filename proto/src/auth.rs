//! Token authentication: every RPC must carry `authorization: Bearer <token>`, one of the
//! tokens its service accepts (the coordinator gives clients and workers different tokens).
//! The comparison takes the same time whatever the mismatch, so a token cannot be guessed
//! byte by byte.

use tonic::{Request, Status};

/// A tonic interceptor that lets through requests carrying one of its tokens.
#[derive(Clone)]
pub struct BearerAuth {
    expected: Vec<Vec<u8>>,
}

impl BearerAuth {
    /// Accepts any of `tokens` (none: refuses every request).
    pub fn new(tokens: &[&str]) -> Self {
        BearerAuth { expected: tokens.iter().map(|t| format!("Bearer {t}").into_bytes()).collect() }
    }

    pub fn check<T>(&self, req: Request<T>) -> Result<Request<T>, Status> {
        let got = req.metadata().get("authorization").map(|v| v.as_bytes()).unwrap_or_default();
        // Compare with every token, so the time does not tell which one came close.
        let matches = self.expected.iter().fold(false, |any, e| constant_time_eq(got, e) | any);
        if matches { Ok(req) } else { Err(Status::unauthenticated("missing or wrong bearer token")) }
    }
}

fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
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

#[cfg(test)]
mod tests {
    use super::*;

    fn with(header: Option<&str>) -> Request<()> {
        let mut r = Request::new(());
        if let Some(h) = header {
            r.metadata_mut().insert("authorization", h.parse().unwrap());
        }
        r
    }

    #[test]
    fn only_the_listed_tokens_pass() {
        let auth = BearerAuth::new(&["client-token", "other-token"]);
        assert!(auth.check(with(Some("Bearer client-token"))).is_ok());
        assert!(auth.check(with(Some("Bearer other-token"))).is_ok());
        for h in [None, Some("Bearer client-toke"), Some("client-token"), Some("Bearer worker-token")] {
            assert_eq!(auth.check(with(h)).unwrap_err().code(), tonic::Code::Unauthenticated, "{h:?}");
        }
        assert!(BearerAuth::new(&[]).check(with(Some("Bearer "))).is_err());
    }
}
