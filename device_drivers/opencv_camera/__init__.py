"""Any camera OpenCV opens: a USB (UVC) camera, a network stream, a video file, an image
folder."""
