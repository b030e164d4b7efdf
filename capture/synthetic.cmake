# The synthetic camera (issue 4 item 1): sources and tests are added here.
