fn main() {
    use detector_core::strategy::track::*;
    println!("TrackCheck {}", core::mem::size_of::<TrackCheck>());
    println!("Calibration {}", core::mem::size_of::<calibration::Calibration>());
    println!("VelocityTest {}", core::mem::size_of::<velocity::VelocityTest>());
    println!("Detector<Kinematic> {}", core::mem::size_of::<detector_core::fusion::Detector<detector_core::strategy::location_shift::KinematicPredictor>>());
    println!("Verdict {}", core::mem::size_of::<detector_core::fusion::Verdict>());
    println!("TrackOutcome {}", core::mem::size_of::<TrackOutcome>());
}
