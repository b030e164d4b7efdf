# Detection (issue 6 item 1): board detectors (mrgingham, OpenCV SB and classic), AprilTag 3 with border-edge
# corner refinement, orientation, screening; analysis/detect.h.
find_package(OpenCV 4.6 REQUIRED COMPONENTS core imgproc imgcodecs calib3d)
# render/ already imported AprilTag; its target is visible here, and a second find_package would fail
# ("some but not all targets already defined"). Only libapriltag itself is used (no image_u8/matd utils).
if(NOT TARGET apriltag::apriltag)
  find_package(apriltag 3 REQUIRED)
endif()
# mrgingham ships no CMake config (dependencies.md).
find_path(MRGINGHAM_INCLUDE_DIR mrgingham/mrgingham.hh REQUIRED)
find_library(MRGINGHAM_LIBRARY mrgingham REQUIRED)

add_library(curvecheck_analysis_detect STATIC
  ${CMAKE_CURRENT_SOURCE_DIR}/detect.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/detect_board.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/detect_tags.cc
)
target_include_directories(curvecheck_analysis_detect SYSTEM PRIVATE ${MRGINGHAM_INCLUDE_DIR})
target_link_libraries(curvecheck_analysis_detect
  PUBLIC curvecheck_render curvecheck_core opencv_core
  PRIVATE opencv_imgproc opencv_imgcodecs opencv_calib3d apriltag::apriltag
          ${MRGINGHAM_LIBRARY})
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_detect)

curvecheck_add_test(detect_test
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/detect_test.cc ${CMAKE_CURRENT_SOURCE_DIR}/detect_board_test.cc
  LIBS curvecheck_analysis_detect curvecheck_capture curvecheck_render opencv_core opencv_imgproc opencv_imgcodecs
       opencv_calib3d)
