# analysis/screenshot: the camera-free check of a correction from a framebuffer capture (screenshot_check.h,
# issue 19 part 2). Links detect (board indexing, tag ids) and pattern; no renderer (its test renders with it).
add_library(curvecheck_analysis_screenshot STATIC screenshot_check.cc)
target_link_libraries(curvecheck_analysis_screenshot PUBLIC curvecheck_detect curvecheck_pattern curvecheck_core
                      nlohmann_json::nlohmann_json PRIVATE opencv_imgproc fmt::fmt)
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_screenshot)
curvecheck_add_test(screenshot_check_test SOURCES screenshot_check_test.cc
                    LIBS curvecheck_analysis_screenshot curvecheck_render curvecheck_detect opencv_imgproc)
