# Real capture: V4L2/UVC webcams through OpenCV, DSLRs through libgphoto2, capture sessions, folder import
# (issue 4 item 3): sources and tests are added here.
find_package(OpenCV 4.6 REQUIRED COMPONENTS core imgproc imgcodecs videoio)
find_package(PkgConfig REQUIRED)
pkg_check_modules(GPHOTO2 REQUIRED IMPORTED_TARGET libgphoto2)
# IMPORTED_TARGET does not mark its include folders as system ones; do it so that -Werror covers our code only.
get_target_property(_gphoto2_includes PkgConfig::GPHOTO2 INTERFACE_INCLUDE_DIRECTORIES)
if(_gphoto2_includes)
  set_target_properties(PkgConfig::GPHOTO2 PROPERTIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES "${_gphoto2_includes}")
endif()

target_sources(curvecheck_capture PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/capture_run.cc
  ${CMAKE_CURRENT_LIST_DIR}/exif.cc
  ${CMAKE_CURRENT_LIST_DIR}/frame_source.cc
  ${CMAKE_CURRENT_LIST_DIR}/gphoto2_source.cc
  ${CMAKE_CURRENT_LIST_DIR}/presenter_display.cc
  ${CMAKE_CURRENT_LIST_DIR}/session.cc
)
# frame_source.h exposes cv::Mat and nlohmann::json; capture_run.cc checks the patterns shown (pattern/).
target_link_libraries(curvecheck_capture
  PUBLIC opencv_core nlohmann_json::nlohmann_json
  PRIVATE curvecheck_pattern fmt::fmt opencv_imgproc opencv_imgcodecs opencv_videoio PkgConfig::GPHOTO2)

curvecheck_add_test(capture_real_test
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/exif_test.cc
    ${CMAKE_CURRENT_LIST_DIR}/frame_source_test.cc
    ${CMAKE_CURRENT_LIST_DIR}/session_test.cc
  LIBS curvecheck_capture opencv_core opencv_imgcodecs)
