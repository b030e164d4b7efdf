# The textured quad and its texture for other applications (pattern_texture.h); its test detects the features in
# the texture, so it links the detectors too (as detect_test links the renderer).
# pattern_files.cc: what `curvecheck render` and `curvecheck pattern` write (pattern_files.h).
target_sources(curvecheck_render PRIVATE pattern_texture.cc pattern_files.cc)
curvecheck_add_test(pattern_texture_test SOURCES pattern_texture_test.cc
                    LIBS curvecheck_analysis_screenshot curvecheck_render curvecheck_detect opencv_imgproc)
