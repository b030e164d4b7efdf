# The synthetic camera (issue 4 item 1). It reads the renderer's pattern.json for the features' ground truth,
# so capture follows render in the pipeline.
target_sources(curvecheck_capture PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/synthetic_camera.cc)
target_link_libraries(curvecheck_capture PUBLIC curvecheck_render curvecheck_datasets opencv_core PRIVATE opencv_imgproc)
curvecheck_add_test(synthetic_camera_test SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/synthetic_camera_test.cc
                    LIBS curvecheck_capture opencv_core opencv_imgproc opencv_calib3d)
