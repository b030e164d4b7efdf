# analysis/pipeline: detect -> verify -> fit for a set of photos, result.json and the overlays (pipeline.h).
find_package(OpenCV 4.6 REQUIRED COMPONENTS core imgproc imgcodecs)
add_library(curvecheck_analysis_pipeline STATIC pipeline.cc)
target_link_libraries(curvecheck_analysis_pipeline
  PUBLIC curvecheck_detect curvecheck_analysis_verify curvecheck_analysis_fit curvecheck_pattern curvecheck_core
  PRIVATE curvecheck_analysis_report opencv_core opencv_imgproc opencv_imgcodecs fmt::fmt)
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_pipeline)
