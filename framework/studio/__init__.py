"""inkmotion studio: the pipeline in a browser (``inkmotion studio``).

- :mod:`.app`: the Starlette app (pages, JSON API, server-sent events) and its guards;
- :mod:`.runner`: the studio's jobs, run here in threads or queued for the workers, each a
  row of the job store, followed live;
- :mod:`.drawing`: a drawing made on the page (pointer events with times) as a GML tag;
- :mod:`.uploads`: what an uploaded file must be before any job exists;
- :mod:`.motion`: a finished job as the page draws and animates it.

Importing this package imports nothing heavy; the app needs Starlette (and uvicorn to
serve it).
"""
