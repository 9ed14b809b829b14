"""The technician's page of a live capture (``volcal capture ... --serve``).

:mod:`.state` keeps what the page shows (fed by the capture's loop), :mod:`.server` serves
it with aiohttp (the ``capture`` extra); ``static/`` holds the page, its script and its
style sheet, served from the package (no CDN). See docs/capture_page.md.
"""
