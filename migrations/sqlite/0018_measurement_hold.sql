-- The instrument hold a measurement was taken under (issue 32): a
-- verification accepted any measurement as the display's emission of a
-- colour, including one taken freely while nothing was on the display.
-- A measurement taken while a calibration or verification held the
-- instrument keeps the hold's id and its purpose; NULL when taken freely.
ALTER TABLE measurements ADD COLUMN hold_id INTEGER;
ALTER TABLE measurements ADD COLUMN hold_purpose TEXT;
