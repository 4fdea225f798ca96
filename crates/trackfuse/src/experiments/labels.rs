//! Which target each local track follows, in the sensor's own (biased) frame.
//!
//! A biased radar's local track follows the target's *image* in that radar's frame
//! (range and bearing shifted by the radar's biases), not the target itself, so labelling
//! it against the true positions fails once the bias exceeds the label gate. 000's
//! P_c (eq. 19) and its local-track rows (Tables 4 and 6) need the label the paper
//! means: the target whose image the track follows. [`biased_frame_labels`] gives it by a
//! gated optimal assignment, per scan and sensor, of the sensor's tracks to the targets'
//! images ([`crate::models::polar::sensor_image`] with the simulator's true biases).

use std::collections::{BTreeMap, HashMap};

use crate::metrics::assignment::gated_assignment;
use crate::models::polar::sensor_image;
use crate::types::{position_of, Id, LocalTrack, Sensor, TruthState, Vec2};

/// `(scan, sensor, local track) -> target`: each sensor's tracks of a scan assigned
/// (optimal assignment, pairs farther than `gate` metres left out) to the images of the
/// targets of that scan in the sensor's biased frame. A track with no target within the
/// gate, or of a sensor not in `sensors`, has no label.
pub fn biased_frame_labels(
    truth: &[TruthState],
    local: &[LocalTrack],
    sensors: &[Sensor],
    gate: f64,
) -> HashMap<(u32, Id, Id), Id> {
    let mut targets: BTreeMap<u32, Vec<(Id, Vec2)>> = BTreeMap::new();
    for t in truth {
        targets
            .entry(t.scan)
            .or_default()
            .push((t.target_id, position_of(&t.state)));
    }
    let mut tracks: BTreeMap<(u32, Id), Vec<(Id, Vec2)>> = BTreeMap::new();
    for l in local {
        tracks
            .entry((l.scan, l.sensor_id))
            .or_default()
            .push((l.track_id, position_of(&l.state)));
    }
    let by_id: HashMap<Id, &Sensor> = sensors.iter().map(|s| (s.id, s)).collect();
    let mut labels = HashMap::with_capacity(local.len());
    let mut images: Vec<Vec2> = Vec::new();
    let mut positions: Vec<Vec2> = Vec::new();
    for ((scan, sensor), ts) in &tracks {
        let (Some(targets), Some(s)) = (targets.get(scan), by_id.get(sensor)) else {
            continue;
        };
        images.clear();
        images.extend(targets.iter().map(|(_, p)| sensor_image(*p, s)));
        positions.clear();
        positions.extend(ts.iter().map(|(_, p)| *p));
        for (li, ti) in gated_assignment(&positions, &images, gate)
            .into_iter()
            .enumerate()
        {
            if let Some(ti) = ti {
                labels.insert((*scan, *sensor, ts[li].0), targets[ti].0);
            }
        }
    }
    labels
}
