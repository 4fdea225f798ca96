//! The HTTP endpoint (axum): `GET /health` (JSON: `status`, the totals) and
//! `GET /metrics` (Prometheus text format).

use crate::metrics::Metrics;
use axum::extract::State;
use axum::http::header;
use axum::response::IntoResponse;
use axum::routing::get;
use axum::Router;
use std::sync::Arc;
use tokio::net::TcpListener;
use tokio::sync::watch;

/// Serve until `stop` turns true.
pub async fn serve(listener: TcpListener, metrics: Arc<Metrics>, mut stop: watch::Receiver<bool>) {
    let app = Router::new()
        .route("/health", get(health))
        .route("/metrics", get(metrics_text))
        .with_state(metrics);
    let shutdown = async move {
        let _ = stop.changed().await;
    };
    if let Err(e) = axum::serve(listener, app)
        .with_graceful_shutdown(shutdown)
        .await
    {
        eprintln!("trackfuse serve: http endpoint: {e}");
    }
}

async fn health(State(m): State<Arc<Metrics>>) -> impl IntoResponse {
    let body = serde_json::json!({
        "status": "ok",
        "instants_fused": m.instants_fused.get(),
        "live_global_tracks": m.live_global_tracks.get(),
        "pending_reports": m.pending_reports.get(),
        "sensor_connections": m.sensor_connections.get(),
        "subscribers": m.subscribers.get(),
    });
    (
        [(header::CONTENT_TYPE, "application/json")],
        body.to_string(),
    )
}

async fn metrics_text(State(m): State<Arc<Metrics>>) -> impl IntoResponse {
    (
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        m.encode(),
    )
}
