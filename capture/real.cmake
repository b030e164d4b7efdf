# Real capture: V4L2/UVC webcams through OpenCV, DSLRs through libgphoto2, capture sessions, folder import
# (issue 4 item 3): sources and tests are added here.
