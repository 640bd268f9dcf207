"""OpenPendant, installed as one package. The repository keeps its parts in top-level folders
(runtime/, device_drivers/, sandbox/, blockly_blocks/, plugins/, webui/, deploy/); this folder
links them in, so the code imports them as `openpendant.runtime`, … in a checkout (an
editable install) and in an installed wheel alike, and nothing generic such as `runtime` or
`plugins` lands at the top of anyone's site-packages."""
