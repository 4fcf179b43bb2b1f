//! Per-system timing from `tracing` spans: a layer that sums, per span name, the number of
//! entries and the time spent inside spans of target `hydrofrac::system`.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tracing::Subscriber;
use tracing::span::{Attributes, Id};
use tracing_subscriber::layer::{Context, Layer};
use tracing_subscriber::registry::LookupSpan;

/// Calls and total time of one system.
#[derive(Clone, Copy, Debug, Default)]
pub struct SystemTime {
    pub calls: u64,
    pub total: Duration,
}

/// Shared table filled by [`TimingLayer`].
pub type TimingTable = Arc<Mutex<BTreeMap<&'static str, SystemTime>>>;

/// The layer. Clone the `table` handle before installing it to read the result.
#[derive(Clone, Default)]
pub struct TimingLayer {
    pub table: TimingTable,
}

struct Entered(Instant);

impl<S> Layer<S> for TimingLayer
where
    S: Subscriber + for<'a> LookupSpan<'a>,
{
    fn on_new_span(&self, _attrs: &Attributes<'_>, _id: &Id, _ctx: Context<'_, S>) {}

    fn on_enter(&self, id: &Id, ctx: Context<'_, S>) {
        if let Some(span) = ctx.span(id)
            && span.metadata().target() == "hydrofrac::system"
        {
            span.extensions_mut().replace(Entered(Instant::now()));
        }
    }

    fn on_exit(&self, id: &Id, ctx: Context<'_, S>) {
        if let Some(span) = ctx.span(id)
            && let Some(Entered(t0)) = span.extensions_mut().remove::<Entered>()
        {
            let dt = t0.elapsed();
            let mut table = self.table.lock().expect("timing table");
            let e = table.entry(span.metadata().name()).or_default();
            e.calls += 1;
            e.total += dt;
        }
    }
}

/// A printable table: system, calls, total seconds, share of the summed time.
pub fn format_table(rows: &[(String, bool, u64, f64)]) -> String {
    let sum: f64 = rows.iter().map(|r| r.3).sum();
    let mut out = format!(
        "{:<18} {:>8} {:>10} {:>12} {:>7}\n",
        "system", "enabled", "calls", "total [s]", "share"
    );
    for (name, enabled, calls, total) in rows {
        let share = if sum > 0.0 { 100.0 * total / sum } else { 0.0 };
        out += &format!(
            "{:<18} {:>8} {:>10} {:>12.4} {:>6.1}%\n",
            name,
            if *enabled { "yes" } else { "no" },
            calls,
            total,
            share
        );
    }
    out
}
