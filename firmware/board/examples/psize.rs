fn main() {
    println!("Pipeline {}", core::mem::size_of::<gnss_guard_board::pipeline::Pipeline<'static>>());
    println!("Predictor {}", core::mem::size_of::<detector_core::strategy::location_shift::Predictor<'static>>());
    println!("Detector {}", core::mem::size_of::<detector_core::fusion::Detector<'static, detector_core::strategy::location_shift::Predictor<'static>>>());
    println!("Synchronizer {}", core::mem::size_of::<detector_core::sync::Synchronizer>());
}
